"""Memory guard: estimate an operation's peak before allocating, refuse what cannot fit.

Without a guard a too-large request (``generate diamond-square --size 65537``: 16 GiB of
float32 heights, several times that at the peak) grows until the kernel's OOM killer ends the
process, or dies in a ``MemoryError`` traceback half-way. Every command that allocates in
proportion to its input estimates its peak first (a per-command model: bytes per sample,
measured with ``/usr/bin/time -v`` and recorded in ``docs/benchmarks.md``) and compares it
with the limit:

* the limit is ``--max-memory`` (e.g. ``4G``, ``512M``, ``50%``), else the environment
  variable ``TERRASCAPE_MAX_MEMORY``, else :data:`DEFAULT_SHARE` of the memory available now
  (``MemAvailable`` in ``/proc/meminfo``, capped by a cgroup ``memory.max`` if one is set;
  ``os.sysconf`` elsewhere);
* over the limit, :class:`~terrascape.errors.MemoryLimitError` names the estimate, the limit
  and what is available, before any work is done (CLI exit code 1).
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

from terrascape.errors import InvalidParameterError, MemoryLimitError

#: Share of the currently available memory one command may use by default.
DEFAULT_SHARE = 0.8
#: Environment variable with the default limit (same syntax as ``--max-memory``).
ENV_VAR = "TERRASCAPE_MAX_MEMORY"

_UNITS = {"": 1, "b": 1, "k": 1024, "kb": 1024, "kib": 1024, "m": 1024**2, "mb": 1024**2,
          "mib": 1024**2, "g": 1024**3, "gb": 1024**3, "gib": 1024**3, "t": 1024**4,
          "tb": 1024**4, "tib": 1024**4}
_limit_override: int | None = None


def _cgroup_headroom() -> int | None:
    """Bytes the cgroup (container) still allows, if it sets a limit (cgroup v2 or v1)."""
    for limit_file, usage_file in (
        ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
        ("/sys/fs/cgroup/memory/memory.limit_in_bytes",
         "/sys/fs/cgroup/memory/memory.usage_in_bytes"),
    ):
        try:
            text = Path(limit_file).read_text().strip()
            if text == "max":
                return None
            limit = int(text)
            if limit >= 1 << 60:  # v1's "unlimited"
                return None
            used = int(Path(usage_file).read_text().strip())
            return max(limit - used, 0)
        except (OSError, ValueError):
            continue
    return None


def available_bytes() -> int:
    """Memory the system can give a new allocation now, in bytes."""
    avail = None
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        avail = None
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic systems
            avail = 8 * 1024**3
    cgroup = _cgroup_headroom()
    return min(avail, cgroup) if cgroup is not None else avail


def parse_memory(text: str | int | float, *, name: str = "--max-memory") -> int:
    """``"4G"``, ``"512M"``, ``"1.5GiB"``, ``"2e9"`` or ``"50%"`` (of available) → bytes."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value = float(text)
        if not math.isfinite(value) or value <= 0:
            raise InvalidParameterError(f"{name} must be > 0 bytes, got {text!r}")
        return int(value)
    t = str(text).strip().lower().replace(" ", "")
    m = re.fullmatch(r"([0-9]*\.?[0-9]+(?:e[+-]?[0-9]+)?)(%|[kmgt]?i?b?)", t)
    if m is None:
        raise InvalidParameterError(
            f"{name} must look like 4G, 512M, 1.5GiB, 2e9 (bytes) or 50% (of available "
            f"memory), got {text!r}"
        )
    value = float(m[1])
    if m[2] == "%":
        if not 0 < value <= 100:
            raise InvalidParameterError(f"{name} as a share must be in (0, 100]%, got {text!r}")
        return int(available_bytes() * value / 100)
    nbytes = value * _UNITS[m[2]]
    if not math.isfinite(nbytes) or nbytes < 1:
        raise InvalidParameterError(f"{name} must be at least 1 byte, got {text!r}")
    return int(nbytes)


def set_limit(limit: str | int | None) -> None:
    """Set the process-wide limit (the CLI's ``--max-memory``); ``None`` restores the default."""
    global _limit_override
    _limit_override = None if limit is None else parse_memory(limit)


def memory_limit() -> int:
    """The limit in bytes: :func:`set_limit`, else ``$TERRASCAPE_MAX_MEMORY``, else the share."""
    if _limit_override is not None:
        return _limit_override
    env = os.environ.get(ENV_VAR)
    if env:
        return parse_memory(env, name=ENV_VAR)
    return int(available_bytes() * DEFAULT_SHARE)


def format_bytes(n: float, digits: int = 3) -> str:
    """``1536 * 1024**2`` → ``"1.5 GiB"`` (``digits`` significant digits)."""
    for unit, size in (("TiB", 1024**4), ("GiB", 1024**3), ("MiB", 1024**2), ("KiB", 1024)):
        if abs(n) >= size:
            return f"{n / size:.{digits}g} {unit}"
    return f"{int(n)} B"


def check_memory(estimate: float, what: str, *, hint: str = "", limit: int | None = None) -> None:
    """Refuse an operation whose estimated peak ``estimate`` (bytes) exceeds the limit.

    Parameters
    ----------
    estimate
        Estimated peak of the operation in bytes (beyond what is already allocated).
    what
        The operation in the user's words, e.g. ``"diamond-square 65537×65537"``.
    hint
        What to change, e.g. ``"use a smaller --size"``.
    limit
        Override of :func:`memory_limit` (bytes).

    Raises
    ------
    MemoryLimitError
        With the estimate, the limit and the available memory.
    """
    if not math.isfinite(estimate):
        estimate = float("inf")
    cap = memory_limit() if limit is None else int(limit)
    if estimate <= cap:
        return
    raise memory_refusal(estimate, what, hint=hint, cap=cap,
                         source="--max-memory" if limit is not None else None)


def memory_refusal(estimate: float, what: str, *, hint: str = "", cap: int | None = None,
                   source: str | None = None) -> MemoryLimitError:
    """The error :func:`check_memory` raises, for an operation already known to need more
    than the limit ``cap`` (default :func:`memory_limit`; e.g. a limit read before a long
    computation that stopped on reaching it). ``source`` names where the limit came from
    (default: ``--max-memory``, the environment variable or the share of available)."""
    if not math.isfinite(estimate):
        estimate = float("inf")
    cap = memory_limit() if cap is None else int(cap)
    avail = available_bytes()
    if source is None:
        source = ("--max-memory" if _limit_override is not None
                  else ENV_VAR if os.environ.get(ENV_VAR)
                  else f"{DEFAULT_SHARE:.0%} of available; --max-memory raises it")
    # just over the limit (a mesh refused as soon as its pieces pass it), three digits
    # would print the same figure twice
    digits = 3
    while digits < 7 and format_bytes(estimate, digits) == format_bytes(cap, digits):
        digits += 1
    need = ("an impossible amount" if math.isinf(estimate)
            else f"about {format_bytes(estimate, digits)}")
    return MemoryLimitError(
        f"{what} needs {need} of memory at its peak (estimate), over the limit of "
        f"{format_bytes(cap, digits)} ({source}; {format_bytes(avail)} available now)"
        + (f"; {hint}" if hint else "")
    )


def check_triangles(count: int, model: str, what: str, *, hint: str = "") -> float:
    """:func:`check_memory` for a mesh of ``count`` triangles, by the bytes per triangle of
    ``PEAK_BYTES_PER_TRIANGLE[model]``; the message reads ``{what} {count} triangles``.
    Returns the estimate (bytes)."""
    estimate = float(count) * PEAK_BYTES_PER_TRIANGLE[model]
    check_memory(estimate, f"{what} {count:,} triangles", hint=hint or MESH_TOO_BIG_HINT)
    return estimate


def grid_bytes(rows: int, cols: int, *, per_sample: float) -> float:
    """Peak estimate of a grid operation: ``rows × cols × per_sample`` bytes (as a float, so
    absurd sizes do not overflow)."""
    return float(rows) * float(cols) * float(per_sample)


#: Peak bytes per grid sample (per output pixel for images) of each command, measured with
#: ``/usr/bin/time -v`` at 2049² and 4097² minus the same command at 65² (the imports and
#: numba's compiler), rounded up by about 20 % (``docs/benchmarks.md``, "Peak memory").
#: Heights are 4 bytes per sample, so 8 means "twice the float32 map".
PEAK_BYTES_PER_SAMPLE: dict[str, float] = {
    "diamond-square": 11.0,
    "fault": 15.0,
    "hills": 15.0,
    "fbm": 23.0,
    "ridged": 23.0,
    "blur": 23.0,
    "erode": 30.0,
    # `shade --lighting classic` (measured 14.2 B at 2049², 10.2 B at 4097²); the daylight
    # model, shade's default, keeps float32 normals, shadows and output and works in bands
    # of rows: measured 35 B grey, 45 B --color at 2049², 29 and 37 B at 4097², 27 B grey
    # at 8193² (`bash scripts/shade_memory_time.sh`, 2026-12-07 14:59 UTC; 165 B before)
    "shade": 17.0,
    "shade daylight": 54.0,
    "normalmap": 16.0,
    "texture regions": 40.0,
    # Photo and terrain materials are made in blocks of rows: the RGB image (3 B), Pillow's
    # copy while encoding (4 B, RGB stored as 4 bytes) and the float32 heightmap read (4 B
    # per sample; per pixel at --scale 1), measured 11 B at 2049² (texture material
    # heights.npy) and 6.9 B for photo-rock at 2048² (no heightmap; its Fourier block comes
    # on top: photo_materials.layer_spectrum_bytes), 2026-12-02.
    "texture material": 13.0,
    "texture photo": 8.5,
    # The photo read (3–4 B a pixel for 8-bit RGB(A), 8 B for a float TIFF), its float64
    # luminance (8 B, blurred in place and high-passed in strips) and the float32 result
    # (4 B): measured 14–18 B (16-bit grey, RGB, RGBA PNG; --blur 2, --highpass 64) and 22 B
    # (float TIFF, --highpass 64) at 4097², 2026-12-02.
    "heightfromimage": 27.0,
    "render": 200.0,
    # `mesh`: the heights and the meshers' per-sample work, before the mesh's own size (a
    # 4097² map meshed at a 50 m error: 14.6 B .ply, 14.5 B .obj), 2026-12-06; a .glb's
    # baked texture, its daylight lightmap now in bands: 42 B at 2049², 45 B at 4097² (167
    # B before; `/usr/bin/time terrascape mesh m.npy -o m.glb --max-error 50`, 2026-12-07)
    "mesh": 18.0,
    "mesh glb": 55.0,
}

#: Peak bytes per triangle of ``terrascape mesh`` by output format: a 4097² fBm map meshed
#: at error 0 (33.5 million triangles) against the same at a 50 m error (.ply 159–173 B,
#: .obj 214–231 B, RTIN and greedy TIN), or for .glb, whose texture is baked in another
#: phase, against a 65² map (166–186 B); rounded up by about 20 % (``docs/benchmarks.md``,
#: "Peak memory of a mesh", 2026-12-06).
PEAK_BYTES_PER_TRIANGLE: dict[str, float] = {
    ".obj": 280.0,
    ".ply": 210.0,
    ".glb": 225.0,
    # `export web` (its compressed glb and the page with it in base64): 139–153 B against
    # a 50 m error (`export blender --format glb` builds the .glb above: 165–168 B against
    # a 65² map), 2026-12-06
    "web": 185.0,
    # the greedy TIN's join of its pieces and its output, checked as the pieces are meshed
    # (their own arrays are part of it) and before the join: `python
    # scripts/greedy_tin_peak_memory.py`, 80.9–81.9 B at error 0 on 2049² and 4097² fBm,
    # 2026-12-06
    "greedy join": 100.0,
    # the greedy TIN as one order (a triangle budget, or `--one-piece`), per slot of its
    # insertion's arrays (64 B: vertices, triangles, twins, candidates, queue; doubled when
    # full), checked before each doubling: `python scripts/greedy_tin_peak_memory.py SIZE 0
    # --one-order`, 73.1 B at 1100² (4,194,304 slots) and 70.8 B at 1500² (8,388,608),
    # 2026-12-07
    "greedy one order": 85.0,
}

#: What to change when a mesh, once built, is refused for its size.
MESH_TOO_BIG_HINT = ("nothing was written; give a larger maximum error (--max-error) or "
                     "raise the limit (--max-memory)")


def estimate_peak(command: str, rows: int, cols: int, *, extra: float = 0.0) -> float:
    """Estimated peak bytes of ``command`` on a ``rows × cols`` grid (plus ``extra`` bytes)."""
    return grid_bytes(rows, cols, per_sample=PEAK_BYTES_PER_SAMPLE[command]) + float(extra)


def gaussian_kernel_bytes(sigma: float, truncate: float = 4.0) -> float:
    """Bytes scipy's 1-D Gaussian needs: float64 weights and their index arrays, radius
    ``truncate·σ`` (a σ of 1e9 is a 64 GB kernel, refused instead of a MemoryError)."""
    radius = truncate * float(sigma) + 0.5
    return 4.0 * 8.0 * (2.0 * radius + 1.0)


def check_grid(
    command: str, rows: int, cols: int, *, hint: str = "use a smaller size", extra: float = 0.0
) -> float:
    """:func:`check_memory` with :func:`estimate_peak`; returns the estimate (bytes)."""
    estimate = estimate_peak(command, rows, cols, extra=extra)
    check_memory(estimate, f"{command} on {cols}×{rows} samples", hint=hint)
    return estimate


__all__ = [
    "DEFAULT_SHARE",
    "ENV_VAR",
    "MESH_TOO_BIG_HINT",
    "PEAK_BYTES_PER_SAMPLE",
    "PEAK_BYTES_PER_TRIANGLE",
    "available_bytes",
    "check_grid",
    "check_memory",
    "check_triangles",
    "estimate_peak",
    "format_bytes",
    "gaussian_kernel_bytes",
    "grid_bytes",
    "memory_limit",
    "parse_memory",
    "set_limit",
]
