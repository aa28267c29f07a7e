"""Diamond-square fractal heightmaps with a selectable roughness decay law.

Filipović 2008 §2.2 describes the subdivision family ("generiranje visinske mape dijeljenjem"):
random corner heights, then repeatedly the centre of every square (diamond step) and the
midpoints of every edge (square step) get the mean of their neighbours plus a random offset
whose amplitude, the *roughness* ``r``, shrinks from level to level. Filipović 2008 §5.3.1 shows
that *how* ``r`` shrinks matters as much as its start value and names three laws, written as
integer C code::

    case LIN:  roughness -= 40;
    case DIV:  roughness >>= 1;
    case SQRT: roughness = sqrt(roughness);

and analyses them for an 8-bit start of 255: linear reaches 0 at depth 7, halving at depth 8,
and the (rounded) square root falls to 1 already at depth 4 — deeper levels add (almost) no
detail. :func:`roughness_schedule` and :func:`detail_depth` reproduce that analysis; the
generator has a float mode (heights in world units) and an ``integer=True`` mode that follows
the thesis's integer arithmetic (integer heights, C-style truncating mean, integer offsets in
``[-r, r]``). A fourth, continuous law ``hurst`` (``r *= 2**-H``) gives fractional-Brownian
surfaces of Hurst exponent ``H`` (``H = 1`` is the halving law).

Level ``k`` (``k = 0`` is the first diamond step over the whole grid, step ``2**n``) uses
``r_k``, the ``k``-th entry of the schedule; the four corners get offsets of amplitude
``r_0`` unless ``corners`` fixes them. A ``(2**n + 1)``-sized grid has ``n`` levels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit, prange
from terrascape._validate import (
    check_finite,
    check_int,
    check_positive,
    check_range,
    check_size_pow2_plus1,
    make_rng,
)
from terrascape.errors import InvalidParameterError
from terrascape.generate._common import seed_meta, spacing_pair
from terrascape.heightmap import Heightmap

DECAY_LAWS = ("linear", "halve", "sqrt", "hurst")
DEFAULT_HURST = 0.8


def _check_decay(decay: str) -> str:
    if not isinstance(decay, str) or decay not in DECAY_LAWS:
        raise InvalidParameterError(
            f"decay must be one of {', '.join(DECAY_LAWS)}, got {decay!r}"
        )
    return decay


def _next_roughness(r: float, decay: str, step: float, hurst: float, integer: bool) -> float:
    """One application of the decay law (Filipović 2008 §5.3.1), in integer or float semantics."""
    if decay == "linear":
        return max(r - step, 0.0)
    if decay == "halve":
        # ``r >>= 1`` on a non-negative int is floor division by two.
        return float(int(r) >> 1) if integer else r / 2.0
    if decay == "sqrt":
        root = math.sqrt(r)
        # The thesis's analysis ("zbog zaokruživanja brojeva") rounds: 255 -> 16 -> 4 -> 2 -> 1.
        return float(math.floor(root + 0.5)) if integer else root
    scaled = r * 2.0 ** (-hurst)
    return float(math.floor(scaled + 0.5)) if integer else scaled


def _resolve_params(
    start: float,
    decay: str,
    step: float | None,
    hurst: float | None,
    integer: bool,
    levels_for_default_step: int,
) -> tuple[float, float, float]:
    decay = _check_decay(decay)
    start = check_positive(start, "roughness", allow_zero=True)
    if integer and start != int(start):
        raise InvalidParameterError(
            f"integer mode needs an integer roughness (the seed uses 255), got {start!r}"
        )
    if step is None:
        # Default linear step: reach zero exactly after the last level.
        step = start / max(levels_for_default_step, 1)
        if integer:
            step = float(max(1, math.ceil(step)))
    else:
        step = check_positive(step, "decay_step")
        if integer and step != int(step):
            raise InvalidParameterError(
                f"integer mode needs an integer decay_step (the seed uses 40), got {step!r}"
            )
    hurst = DEFAULT_HURST if hurst is None else check_range(hurst, "hurst", 0.0, 1.0)
    return start, float(step), float(hurst)


def roughness_schedule(
    start: float,
    decay: str,
    *,
    step: float | None = None,
    hurst: float | None = None,
    integer: bool = False,
    levels: int = 16,
) -> np.ndarray:
    """Roughness per subdivision depth, ``r_0 = start`` then the decay law applied repeatedly.

    Parameters
    ----------
    start
        Roughness at depth 0 (the thesis's 8-bit set-up uses 255). ``>= 0``.
    decay
        ``"linear"`` (``r -= step``, floored at 0), ``"halve"`` (``r >>= 1`` in integer mode,
        ``r / 2`` otherwise), ``"sqrt"`` (``r = sqrt(r)``, rounded in integer mode) or
        ``"hurst"`` (``r *= 2**-hurst``, rounded in integer mode) — Filipović 2008 §5.3.1.
    step
        Linear decrement (seed: 40). Default: ``start / levels`` so the schedule reaches 0 at
        the last depth (rounded up to an integer in integer mode).
    hurst
        Hurst exponent in ``[0, 1]`` for ``decay="hurst"`` (default 0.8).
    integer
        Follow the thesis's integer arithmetic.
    levels
        Number of depths returned (``>= 1``).

    Returns
    -------
    numpy.ndarray
        float64 array ``[r_0, r_1, ..., r_{levels-1}]``.
    """
    levels = check_int(levels, "levels", minimum=1, maximum=100_000)
    r, step, hurst = _resolve_params(start, decay, step, hurst, integer, levels)
    out = np.empty(levels, dtype=np.float64)
    for k in range(levels):
        out[k] = r
        r = _next_roughness(r, decay, step, hurst, integer)
    return out


def detail_depth(
    start: float,
    decay: str,
    *,
    step: float | None = None,
    hurst: float | None = None,
    integer: bool = False,
    tol: float | None = None,
    max_depth: int = 100_000,
) -> int:
    """Depth at which a decay law stops adding detail (Filipović 2008 §5.3.1 analysis).

    That is the first depth ``d`` where ``r_d <= tol`` (the offsets vanish) or where the law
    has reached a fixed point, ``|r_{d+1} - r_d| <= tol`` (every deeper level adds the same
    tiny amplitude — the rounded square root sticks at 1). In integer mode ``tol`` defaults
    to 0, which gives the thesis's figures for ``start=255``: linear (``step=40``) → 7,
    halving → 8, rounded square root → 4. In float mode the halving and Hurst laws never reach
    0, so ``tol`` defaults to ``1e-3 * start``.

    Returns
    -------
    int
        The depth, or ``max_depth`` if the criterion is never met before it.
    """
    max_depth = check_int(max_depth, "max_depth", minimum=1)
    r, step, hurst = _resolve_params(start, decay, step, hurst, integer, 16)
    if tol is None:
        tol = 0.0 if integer else 1e-3 * r
    tol = check_positive(tol, "tol", allow_zero=True)
    for depth in range(max_depth):
        nxt = _next_roughness(r, decay, step, hurst, integer)
        if r <= tol or abs(nxt - r) <= tol:
            return depth
        r = nxt
    return max_depth


# --- kernels ---------------------------------------------------------------------------------


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _ds_float_kernel(h, u, rough):  # pragma: no cover - compiled
    """In-place diamond-square on float32 ``h`` (corners already set) with offsets
    ``rough[level] * (2 u - 1)``. ``u[i, j]`` is the uniform draw owned by sample (i, j): each
    sample is written once, so the result does not depend on the (parallel) visiting order."""
    n = h.shape[0]
    s = n - 1
    level = 0
    while s > 1:
        half = s // 2
        r = np.float32(rough[level])
        two_r = np.float32(2.0) * r
        quarter = np.float32(0.25)
        # Diamond step: square centres from their four corners.
        ncent = (n - 1) // s
        for ci in prange(ncent):
            i = half + ci * s
            for j in range(half, n, s):
                avg = (h[i - half, j - half] + h[i - half, j + half]
                       + h[i + half, j - half] + h[i + half, j + half]) * quarter
                h[i, j] = avg + (two_r * u[i, j] - r)
        # Square step: edge midpoints from the (up to four) diamond neighbours; at the border
        # only three exist and the mean is over those (no wrap-around).
        nrows = (n - 1) // half + 1
        for ri in prange(nrows):
            i = ri * half
            j0 = half if (ri % 2 == 0) else 0
            for j in range(j0, n, s):
                acc = np.float32(0.0)
                cnt = 0
                if i >= half:
                    acc += h[i - half, j]
                    cnt += 1
                if i + half < n:
                    acc += h[i + half, j]
                    cnt += 1
                if j >= half:
                    acc += h[i, j - half]
                    cnt += 1
                if j + half < n:
                    acc += h[i, j + half]
                    cnt += 1
                h[i, j] = acc / np.float32(cnt) + (two_r * u[i, j] - r)
        s = half
        level += 1


@njit(cache=CACHE, fastmath=FASTMATH)
def _c_div(a, b):  # pragma: no cover - compiled
    """C integer division (truncation toward zero), as in the thesis's integer implementation."""
    q = abs(a) // b
    return q if a >= 0 else -q


@njit(cache=CACHE, fastmath=FASTMATH)
def _int_offset(u, r):  # pragma: no cover - compiled
    """Uniform integer in ``[-r, r]`` from a uniform ``u`` in ``[0, 1)``."""
    k = np.int64(np.float64(u) * (2 * r + 1))
    if k > 2 * r:  # guard against u rounding up to 1
        k = 2 * r
    return k - r


@njit(cache=CACHE, fastmath=FASTMATH, parallel=True)
def _ds_int_kernel(h, u, rough):  # pragma: no cover - compiled
    """Integer diamond-square on int64 ``h``: truncating means, integer offsets in [-r, r]."""
    n = h.shape[0]
    s = n - 1
    level = 0
    while s > 1:
        half = s // 2
        r = np.int64(rough[level])
        ncent = (n - 1) // s
        for ci in prange(ncent):
            i = half + ci * s
            for j in range(half, n, s):
                tot = (h[i - half, j - half] + h[i - half, j + half]
                       + h[i + half, j - half] + h[i + half, j + half])
                h[i, j] = _c_div(tot, 4) + _int_offset(u[i, j], r)
        nrows = (n - 1) // half + 1
        for ri in prange(nrows):
            i = ri * half
            j0 = half if (ri % 2 == 0) else 0
            for j in range(j0, n, s):
                tot = np.int64(0)
                cnt = 0
                if i >= half:
                    tot += h[i - half, j]
                    cnt += 1
                if i + half < n:
                    tot += h[i + half, j]
                    cnt += 1
                if j >= half:
                    tot += h[i, j - half]
                    cnt += 1
                if j + half < n:
                    tot += h[i, j + half]
                    cnt += 1
                h[i, j] = _c_div(tot, cnt) + _int_offset(u[i, j], r)
        s = half
        level += 1


# --- public API ------------------------------------------------------------------------------


def _corner_values(
    corners: float | Sequence[float] | None, integer: bool
) -> list[float] | None:
    if corners is None:
        return None
    values = [corners] * 4 if np.isscalar(corners) else list(corners)  # type: ignore[list-item]
    if len(values) != 4:
        raise InvalidParameterError(
            "corners must be one number or 4 numbers (top-left, top-right, bottom-left, "
            f"bottom-right), got {len(values)} values"
        )
    out = [check_finite(v, "corner height") for v in values]
    if integer and any(v != int(v) for v in out):
        raise InvalidParameterError(f"integer mode needs integer corner heights, got {out}")
    return out


def diamond_square(
    size: int,
    *,
    roughness: float = 1.0,
    decay: str = "halve",
    decay_step: float | None = None,
    hurst: float | None = None,
    seed: int | np.random.Generator | None = 0,
    spacing: float | tuple[float, float] = 1.0,
    corners: float | Sequence[float] | None = None,
    integer: bool = False,
) -> Heightmap:
    """Diamond-square heightmap of ``size × size`` samples (``size = 2**n + 1``).

    Filipović 2008 §2.2 (midpoint subdivision, diamond-square variant) with the roughness decay laws
    of §5.3.1; see the module docstring for the level/roughness convention.

    Parameters
    ----------
    size
        Side length, ``2**n + 1`` (e.g. 257, 513, 1025, 4097); else
        :class:`~terrascape.errors.HeightmapSizeError`.
    roughness
        Offset amplitude ``r_0`` of the first level, in world height units (``>= 0``).
    decay
        ``"linear"``, ``"halve"``, ``"sqrt"`` or ``"hurst"`` (see :func:`roughness_schedule`).
    decay_step
        Decrement of the linear law; default ``roughness / n`` (reaches 0 after the last level).
    hurst
        Hurst exponent for ``decay="hurst"`` (``[0, 1]``, default 0.8).
    seed
        Seed (or numpy Generator); the same seed gives the same bytes.
    spacing
        Sample spacing ``dx`` or ``(dx, dz)`` in world units.
    corners
        Fixed corner heights (one number, or top-left, top-right, bottom-left, bottom-right);
        default: random in ``[-r_0, r_0]``.
    integer
        Follow the thesis's integer arithmetic: integer roughness/step, integer heights,
        C-truncating means and integer offsets uniform in ``[-r, r]``.

    Returns
    -------
    Heightmap
        float32 heights; ``metadata`` records the generator and its parameters.
    """
    size = check_size_pow2_plus1(size, algorithm="diamond-square")
    levels = (size - 1).bit_length() - 1
    rough = roughness_schedule(
        roughness, decay, step=decay_step, hurst=hurst, integer=integer, levels=levels
    )
    fixed = _corner_values(corners, integer)
    rng = make_rng(seed)
    # One bulk draw: u[i, j] belongs to sample (i, j) (each sample is set exactly once).
    u = rng.random((size, size), dtype=np.float32)
    idx = ((0, 0), (0, size - 1), (size - 1, 0), (size - 1, size - 1))
    if integer:
        h = np.zeros((size, size), dtype=np.int64)
        r0 = int(rough[0])
        for k, (i, j) in enumerate(idx):
            if fixed is not None:
                h[i, j] = int(fixed[k])
            else:
                h[i, j] = min(int(np.float64(u[i, j]) * (2 * r0 + 1)), 2 * r0) - r0
        _ds_int_kernel(h, u, rough)
        heights = h.astype(np.float32)
    else:
        heights = np.zeros((size, size), dtype=np.float32)
        r0 = np.float32(rough[0])
        for k, (i, j) in enumerate(idx):
            if fixed is not None:
                heights[i, j] = np.float32(fixed[k])
            else:
                heights[i, j] = np.float32(2.0) * r0 * u[i, j] - r0
        _ds_float_kernel(heights, u, rough)
    meta = {
        "generator": "diamond_square",
        "roughness": float(roughness),
        "decay": decay,
        "integer": bool(integer),
        "seed": seed_meta(seed),
        "roughness_schedule": [float(x) for x in rough],
    }
    return Heightmap(heights, spacing_pair(spacing), meta)


__all__ = ["DECAY_LAWS", "detail_depth", "diamond_square", "roughness_schedule"]
