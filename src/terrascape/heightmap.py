"""The heightmap model: float32 heights in world units on a regular X/Z grid, Y up.

Arrays are indexed ``[row, col]`` = ``[z, x]``. ``spacing`` is the world distance between
neighbouring samples along X (columns) and Z (rows).

Georeference (optional, kept by the GeoTIFF reader/writer): ``crs`` names the coordinate
reference system (an ``"EPSG:…"`` string or WKT), ``origin`` is the ``(x, y)`` CRS coordinate
of the OUTER corner of sample ``[0, 0]``'s cell — the ``(c, f)`` of GDAL's geotransform, the
north-west corner of a north-up raster — and rows run south (``y`` decreases with the row).
The centre of sample ``[r, c]`` is at ``(x0 + (c + ½)·px, y0 − (r + ½)·py)`` with ``(px, py)``
the pixel size in CRS units (``spacing`` for projected CRSs; degrees for geographic ones, whose
``spacing`` is converted to metres). ``nodata`` is the value the source used for missing
samples (they are filled on read; writers restore it where the source had holes).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrascape._validate import (
    as_height_array,
    check_positive,
    check_pow2_plus1_square,
    is_pow2_plus1,
)
from terrascape.errors import InvalidParameterError


def normalise_into(heights: np.ndarray, out: np.ndarray, lo: float, hi: float) -> None:
    """Write ``heights`` linearly mapped to ``[lo, hi]`` into the float32 ``out`` (which may
    be ``heights`` itself); a flat map becomes all ``lo``.

    The float64 arithmetic runs over blocks of rows, so the peak is ``out`` plus one small
    block rather than float64 temporaries of the whole map.
    """
    low, high = float(heights.min()), float(heights.max())
    span = high - low
    step = max(1, min(heights.shape[0] // 16, (1 << 16) // max(1, heights.shape[1])))
    for r0 in range(0, heights.shape[0], step):
        unit = heights[r0:r0 + step].astype(np.float64)
        if span > 0:
            unit -= low
            unit /= span
        else:
            unit[...] = 0.0
        unit *= hi - lo
        unit += lo
        out[r0:r0 + step] = unit


@dataclass(frozen=True, eq=False)
class Heightmap:
    """Heights (float32, world units) plus sample spacing; immutable, operations return new maps.

    Parameters
    ----------
    heights
        2-D array ``[rows(z), cols(x)]``; converted to C-contiguous float32. NaN is rejected.
    spacing
        ``(dx, dz)``: world units between samples along X (columns) and Z (rows).
    metadata
        Free-form reader information (source file, on-disk dtype, ...).
    origin
        ``(x, y)`` CRS coordinate of the outer corner of sample ``[0, 0]`` (see the module
        docstring); ``(0, 0)`` for a map without a georeference.
    crs
        ``"EPSG:…"`` or WKT string, or ``None`` (a local grid).
    nodata
        The source's nodata value, or ``None``.
    """

    heights: np.ndarray
    spacing: tuple[float, float] = (1.0, 1.0)
    metadata: dict = field(default_factory=dict)
    origin: tuple[float, float] = (0.0, 0.0)
    crs: str | None = None
    nodata: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "heights", as_height_array(self.heights))
        sp = self.spacing
        if np.isscalar(sp):
            sp = (sp, sp)
        if len(sp) != 2:
            raise InvalidParameterError(f"spacing must be (dx, dz), got {self.spacing!r}")
        sp = (check_positive(sp[0], "spacing dx"), check_positive(sp[1], "spacing dz"))
        object.__setattr__(self, "spacing", sp)
        try:
            ox, oy = (float(v) for v in self.origin)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"origin must be (x, y), got {self.origin!r}") from None
        if not (np.isfinite(ox) and np.isfinite(oy)):
            raise InvalidParameterError(f"origin must be finite, got {self.origin!r}")
        object.__setattr__(self, "origin", (ox, oy))
        if self.crs is not None and (not isinstance(self.crs, str) or not self.crs.strip()):
            raise InvalidParameterError(f"crs must be an EPSG/WKT string or None, got {self.crs!r}")
        if self.nodata is not None:
            nd = float(self.nodata)
            if np.isnan(nd):
                raise InvalidParameterError("nodata must be a number (NaN is implied for floats)")
            object.__setattr__(self, "nodata", nd)
        self.heights.flags.writeable = False

    # --- shape -------------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape  # type: ignore[return-value]

    @property
    def rows(self) -> int:
        return self.heights.shape[0]

    @property
    def cols(self) -> int:
        return self.heights.shape[1]

    @property
    def extent(self) -> tuple[float, float]:
        """World size ``(width_x, depth_z)`` covered by the samples."""
        return ((self.cols - 1) * self.spacing[0], (self.rows - 1) * self.spacing[1])

    @property
    def min(self) -> float:
        return float(self.heights.min())

    @property
    def max(self) -> float:
        return float(self.heights.max())

    @property
    def is_pow2_plus1(self) -> bool:
        """True when the map is square with side 2**n + 1."""
        return self.rows == self.cols and is_pow2_plus1(self.rows)

    def require_pow2_plus1(self, algorithm: str) -> int:
        """Return the side or raise :class:`~terrascape.errors.HeightmapSizeError`."""
        return check_pow2_plus1_square(self.shape, algorithm=algorithm)

    # --- pure operations ---------------------------------------------------------------
    @property
    def georeferenced(self) -> bool:
        """True when the map carries a coordinate reference system."""
        return self.crs is not None

    def with_heights(self, heights: np.ndarray) -> Heightmap:
        """Same spacing, metadata and georeference, new heights."""
        return Heightmap(heights, self.spacing, dict(self.metadata), self.origin, self.crs,
                         self.nodata)

    def to_pow2_plus1(self, mode: str = "pad") -> Heightmap:
        """Make a square 2**n + 1 map.

        ``mode="pad"`` extends to the next 2**n + 1 >= max(rows, cols) by repeating edge
        samples (original samples unchanged, spacing unchanged); ``mode="resample"`` resizes
        with cubic interpolation to the nearest 2**n + 1 of the larger side, adjusting the
        spacing so the world extent is kept.
        """
        if self.is_pow2_plus1:
            return self
        n = max(self.rows, self.cols)
        if mode == "pad":
            side = 3
            while side < n:
                side = (side - 1) * 2 + 1
            padded = np.pad(
                self.heights, ((0, side - self.rows), (0, side - self.cols)), mode="edge"
            )
            return self.with_heights(padded)
        if mode == "resample":
            lo = 3
            while (lo - 1) * 2 + 1 <= n:
                lo = (lo - 1) * 2 + 1
            hi = (lo - 1) * 2 + 1
            side = lo if (n - lo) <= (hi - n) else hi
            # scipy.ndimage takes longer to import than numpy; only this resample needs it.
            from terrascape.filters.resample import resample_cubic

            out = resample_cubic(self.heights, (side, side))
            spacing = (self.extent[0] / (side - 1), self.extent[1] / (side - 1))
            return Heightmap(out, spacing, dict(self.metadata), self.origin, self.crs,
                             self.nodata)
        raise InvalidParameterError(f"mode must be 'pad' or 'resample', got {mode!r}")

    def normalised(self, lo: float = 0.0, hi: float = 1.0) -> Heightmap:
        """Heights linearly mapped to ``[lo, hi]`` (a flat map becomes all ``lo``)."""
        out = np.empty(self.heights.shape, dtype=np.float32)
        normalise_into(self.heights, out, lo, hi)
        return self.with_heights(out)

    def scaled(self, factor: float) -> Heightmap:
        """Heights multiplied by ``factor`` (vertical exaggeration)."""
        return self.with_heights(self.heights * np.float32(factor))

    def gradient(self) -> tuple[np.ndarray, np.ndarray]:
        """``(dh/dx, dh/dz)`` in world units per world unit (central differences inside)."""
        dz, dx = np.gradient(self.heights.astype(np.float64), self.spacing[1], self.spacing[0])
        return dx.astype(np.float32), dz.astype(np.float32)

    def normals(self) -> np.ndarray:
        """Unit surface normals ``(rows, cols, 3)`` as ``(x, y, z)``, Y up: ``(-hx, 1, -hz)``."""
        hx, hz = self.gradient()
        n = np.stack([-hx, np.ones_like(hx), -hz], axis=-1)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        return n.astype(np.float32)

    def slope(self) -> np.ndarray:
        """Slope angle in radians (0 = flat), ``(rows, cols)`` float32.

        Computed over blocks of rows with a one-row halo (the same central and border
        differences as :meth:`gradient` on the whole map), so the peak is the result plus
        one block, not float64 gradients of the whole map.
        """
        h = self.heights
        rows, cols = h.shape
        out = np.empty(h.shape, dtype=np.float32)
        step = max(1, min(rows // 16, (1 << 16) // max(1, cols)))
        for r0 in range(0, rows, step):
            r1 = min(rows, r0 + step)
            lo, hi = max(0, r0 - 1), min(rows, r1 + 1)
            dz, dx = np.gradient(h[lo:hi].astype(np.float64), self.spacing[1], self.spacing[0])
            block = np.arctan(np.hypot(dx.astype(np.float32), dz.astype(np.float32)))
            out[r0:r1] = block[r0 - lo:r1 - lo]
        return out

    def _repr_png_(self) -> bytes:
        """A small shaded, height-coloured PNG, so a heightmap shows itself in Jupyter
        (:func:`terrascape.notebook.heightmap_preview`, at most 256 pixels a side)."""
        from terrascape.notebook import as_image

        return as_image(self).to_png()

    def __repr__(self) -> str:
        return (
            f"Heightmap({self.cols}×{self.rows}, spacing={self.spacing}, "
            f"range=[{self.min:.4g}, {self.max:.4g}])"
        )
