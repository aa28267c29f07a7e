"""Test height fields for relief texturing: a "city" of boxes, fences and a natural field.

Both are *tileable* (periodic) ``float32`` arrays of heights in ``[0, 1]`` (1 = the polygon
surface, 0 = the deepest point), indexed ``[row (v), col (u)]`` like every texture in
terrascape. Relief shaders read *depth* ``1 - h`` (§2.4.7: depth 0 at the polygon,
1 at the bottom). The city is the hard case the thesis's urban tests use (§2.7.2: blocks,
streets, thin walls that a coarse linear search steps over); the natural field is the smooth
case (§2.7.1 test 3).

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.4.7, §2.7.
"""

from __future__ import annotations

import numpy as np

from terrascape._validate import check_int, check_range, make_rng
from terrascape.errors import HeightmapSizeError, InvalidParameterError


def _check_size(size: int, *, pow2: bool = True) -> int:
    n = check_int(size, "size (texels)", minimum=8, maximum=8192)
    if not pow2:
        if n % 2:
            raise HeightmapSizeError(f"natural_field needs an even size, got {n}")
        return n
    if n & (n - 1):
        raise HeightmapSizeError(
            f"relief test fields are tileable power-of-two textures (e.g. 64, 256, 1024), "
            f"got size {n}"
        )
    return n


def city_field(
    size: int = 256,
    *,
    seed: int = 0,
    block: int = 32,
    street: int = 4,
    min_height: float = 0.25,
) -> np.ndarray:
    """A tileable city: a grid of blocks separated by streets, each block holding boxes.

    Every block (``block`` texels pitch, of which ``street`` are street at height 0) is
    split at random into one to four lots. A lot is either a solid box of random height in
    ``[min_height, 1]`` or a courtyard building: a box whose walls are only 1 or 2 texels
    thick around a deep yard — the thin features that make linear search skip (§2.4.7).

    Parameters
    ----------
    size
        Texels per side, a power of two ≥ 8 (the field tiles).
    seed
        Random seed (same seed → same bytes).
    block, street
        Block pitch and street width in texels; ``street < block``.
    min_height
        Lowest roof height, in ``(0, 1]``.

    Returns
    -------
    numpy.ndarray
        float32 ``(size, size)`` heights in ``[0, 1]``; at least one roof is at exactly 1.
    """
    n = _check_size(size)
    block = check_int(block, "block (texels)", minimum=4, maximum=n)
    street = check_int(street, "street (texels)", minimum=1, maximum=block - 3)
    min_height = check_range(min_height, "min_height", 1e-3, 1.0)
    rng = make_rng(seed)
    h = np.zeros((n, n), dtype=np.float32)
    inner = block - street
    for r0 in range(0, n - block + 1, block):
        for c0 in range(0, n - block + 1, block):
            lots = _split_lot(rng, (r0, c0, inner, inner), depth=2)
            for lr, lc, lh, lw in lots:
                roof = np.float32(rng.uniform(min_height, 1.0))
                if lh >= 6 and lw >= 6 and rng.random() < 0.45:
                    wall = int(rng.integers(1, 3))  # 1- or 2-texel walls
                    h[lr : lr + lh, lc : lc + lw] = roof
                    yard = np.float32(rng.uniform(0.0, 0.3 * roof))
                    h[lr + wall : lr + lh - wall, lc + wall : lc + lw - wall] = yard
                else:
                    h[lr : lr + lh, lc : lc + lw] = roof
    h[np.unravel_index(int(np.argmax(h)), h.shape)] = 1.0
    return h


def _split_lot(rng, lot, depth):
    r, c, hh, ww = lot
    if depth == 0 or min(hh, ww) < 8 or rng.random() < 0.3:
        return [lot]
    if ww >= hh:  # split the longer side, leaving a 1-texel alley
        cut = int(rng.integers(3, ww - 3))
        a, b = (r, c, hh, cut), (r, c + cut + 1, hh, ww - cut - 1)
    else:
        cut = int(rng.integers(3, hh - 3))
        a, b = (r, c, cut, ww), (r + cut + 1, c, hh - cut - 1, ww)
    return _split_lot(rng, a, depth - 1) + _split_lot(rng, b, depth - 1)


def natural_field(size: int = 256, *, seed: int = 0, beta: float = 3.2) -> np.ndarray:
    """A smooth tileable natural relief: spectral-synthesis fBm, normalised to ``[0, 1]``.

    The amplitude spectrum falls as ``f^(-beta/2)`` (power ``f^-beta``; ``beta = 3.2`` is a
    rolling landscape, larger is smoother). Synthesised on the FFT grid, so it tiles exactly.

    Parameters
    ----------
    size
        Texels per side, even, ≥ 8 (1280 reproduces the thesis's natural texture, §2.7).
    seed
        Random seed.
    beta
        Spectral exponent in ``[1, 6]``.

    Returns
    -------
    numpy.ndarray
        float32 ``(size, size)`` heights with min 0 and max 1.
    """
    n = _check_size(size, pow2=False)
    beta = check_range(beta, "beta", 1.0, 6.0)
    rng = make_rng(seed)
    fy = np.fft.fftfreq(n)[:, None]
    fx = np.fft.rfftfreq(n)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    amp = f ** (-beta / 2.0)
    amp[0, 0] = 0.0
    # Drop the highest octave so the field is smooth at texel scale (a "natural" surface).
    amp[f > 0.25] = 0.0
    phase = rng.uniform(0.0, 2.0 * np.pi, size=amp.shape)
    spectrum = amp * np.exp(1j * phase)
    h = np.fft.irfft2(spectrum, s=(n, n))
    h = (h - h.min()) / (h.max() - h.min())
    return h.astype(np.float32)


def fence_field(
    size: int = 256,
    *,
    seed: int = 0,
    fences: int = 24,
    min_height: float = 0.4,
    ground: float = 0.0,
) -> np.ndarray:
    """A tileable field of one-texel-thick fences on flat ground: the thinnest walls.

    ``fences`` straight fences, each along a row or a column at a random offset, of a
    random length (a quarter to the whole period) and height in ``[min_height, 1]``. A
    linear search whose step is longer than one texel of the ray passes straight through
    them; only a search that visits every texel the ray crosses (the min/max tracer) is
    sure to find them.

    Returns
    -------
    numpy.ndarray
        float32 ``(size, size)`` heights in ``[0, 1]``; the tallest fence is at exactly 1.
    """
    n = _check_size(size)
    k = check_int(fences, "fences", minimum=1, maximum=4 * n)
    low = check_range(min_height, "min_height", 1e-3, 1.0)
    base = check_range(ground, "ground", 0.0, low)
    rng = make_rng(seed)
    h = np.full((n, n), base, dtype=np.float32)
    for i in range(k):
        top = np.float32(1.0 if i == 0 else rng.uniform(low, 1.0))
        along_rows = bool(rng.integers(0, 2))
        offset = int(rng.integers(0, n))
        start = int(rng.integers(0, n))
        length = int(rng.integers(max(2, n // 4), n + 1))
        idx = (start + np.arange(length)) % n
        if along_rows:
            h[offset, idx] = np.maximum(h[offset, idx], top)
        else:
            h[idx, offset] = np.maximum(h[idx, offset], top)
    return h


def sampled_heights(heights, bits: int) -> np.ndarray:
    """The heights a relief shader actually samples from a texture of ``bits`` precision.

    The packed 8- and 16-bit relief textures store ``round((h − min)/(max − min)·maxval)``
    (:func:`terrascape.lighting.normals.pack_normal_height`); the GPU reads
    ``code / maxval``. Acceleration structures (min/max pyramids, cone maps, wall tests) and
    the exact reference must be built from these values, not from the heights before
    quantisation, or the "exact" tracer traces a different surface from the one it shades.
    Packing the returned heights again gives the same codes. ``bits = 32`` (float32
    textures) returns the heights as float32.
    """
    h = np.asarray(heights, dtype=np.float32)
    if bits == 32:
        return h.copy()
    if bits not in (8, 16) or isinstance(bits, bool):
        raise InvalidParameterError(f"bits must be 8, 16 or 32, got {bits!r}")
    maxval = float((1 << bits) - 1)
    h64 = h.astype(np.float64)
    span = float(h64.max() - h64.min())
    unit = (h64 - h64.min()) / span if span > 0 else np.zeros_like(h64)
    codes = np.rint(unit * maxval).clip(0, maxval)
    return (codes / maxval).astype(np.float32)


# A height step of a quarter of the depth range between neighbouring texels is a wall, not a
# slope: the smooth test field stays below 0.08 (256²) / 0.04 (1280²), the city reaches 1 (tested).
WALL_STEP = 0.25


def max_texel_step(heights) -> float:
    """Largest height difference between 4-neighbouring texels, the field tiled (the wrap
    pair counts: relief textures repeat)."""
    h = np.asarray(heights, dtype=np.float32)
    if h.ndim != 2 or min(h.shape) < 2:
        raise HeightmapSizeError(f"heights must be a (rows, cols) array, got shape {h.shape}")
    rows = np.abs(h - np.roll(h, 1, axis=0)).max()
    cols = np.abs(h - np.roll(h, 1, axis=1)).max()
    return float(max(rows, cols))


def has_walls(heights, step: float = WALL_STEP) -> bool:
    """Does the height field (heights in [0, 1]) have walls: neighbouring texels at least
    ``step`` of the depth range apart? Relief mapping's linear search steps over walls one
    or two texels thick, so its default search is denser on such fields
    (:class:`terrascape.render.relief_quad.ReliefSettings`)."""
    step = check_range(step, "wall step", 1e-6, 1.0)
    return max_texel_step(heights) >= step


__all__ = [
    "WALL_STEP",
    "city_field",
    "fence_field",
    "has_walls",
    "max_texel_step",
    "natural_field",
    "sampled_heights",
]
