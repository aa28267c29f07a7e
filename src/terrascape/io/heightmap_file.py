"""Format dispatch: :func:`read_heightmap` / :func:`write_heightmap` by file extension.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §2.1.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io._common import check_heightmap, check_input_path, normalise_size
from terrascape.io.cog import write_cog
from terrascape.io.exr import read_exr, write_exr, write_exr_half
from terrascape.io.geotiff import read_geotiff, write_geotiff
from terrascape.io.image import read_image, write_png16, write_preview
from terrascape.io.npy import read_npy, write_npy
from terrascape.io.raw import read_raw16, read_raw32, write_raw16, write_raw32
from terrascape.io.terragen import read_terragen, write_terragen

#: Supported extensions → (reads, writes, description). Used for ``--help`` texts.
FORMATS: dict[str, tuple[bool, bool, str]] = {
    ".png": (True, True, "PNG: read 8/16-bit gray or RGB(A); write 16-bit gray + terrascape chunk"),
    ".bmp": (True, True, "BMP: read 8-bit gray/RGB; write 8-bit normalised preview (lossy)"),
    ".jpg": (True, False, "JPEG: read only (8-bit gray/RGB)"),
    ".jpeg": (True, False, "JPEG: read only (8-bit gray/RGB)"),
    ".r16": (True, True, "RAW uint16 little-endian (+ .json sidecar on write)"),
    ".raw": (True, True, "RAW uint16 little-endian, same as .r16"),
    ".r32": (True, True, "RAW float32 little-endian (+ .json sidecar on write)"),
    ".tif": (True, True, "(Geo)TIFF any int/float type in (nodata filled); float32 out, CRS kept"),
    ".tiff": (True, True, "same as .tif"),
    ".npy": (True, True, "NumPy 2-D array; float32 out + .npy.json sidecar (spacing)"),
    ".ter": (True, True, "Terragen terrain (int16 + HeightScale/BaseHeight)"),
    ".exr": (True, True, "OpenEXR one channel, real heights; float32 out (exr16: half)"),
}


@dataclass(frozen=True)
class FormatMetadata:
    """What a written heightmap file keeps, for the warnings of :func:`write_heightmap`.

    ``world_units``: heights read back in world units (not normalised); ``spacing``: the
    sample spacing is stored; ``exact``: float32 heights, not quantised codes.
    """

    world_units: bool
    spacing: bool
    exact: bool
    how: str


#: Per written format (extension or ``format=`` name): what reads back and from where.
WRITE_METADATA: dict[str, FormatMetadata] = {
    "png": FormatMetadata(True, True, False, "16-bit codes + terrascape text chunk"),
    "png16": FormatMetadata(True, True, False, "16-bit codes + terrascape text chunk"),
    "png8": FormatMetadata(True, True, False, "8-bit codes (256 levels) + terrascape chunk"),
    "bmp": FormatMetadata(False, False, False, "8-bit preview, no metadata"),
    "r16": FormatMetadata(True, True, False, "uint16 codes + .json sidecar"),
    "raw": FormatMetadata(True, True, False, "uint16 codes + .json sidecar"),
    "r32": FormatMetadata(True, True, True, "float32 + .json sidecar"),
    "tif": FormatMetadata(True, True, True, "float32 + ModelPixelScale tag"),
    "tiff": FormatMetadata(True, True, True, "float32 + ModelPixelScale tag"),
    "cog": FormatMetadata(True, True, True, "float32 Cloud-Optimized GeoTIFF + overviews"),
    "npy": FormatMetadata(True, True, True, "float32 + .npy.json sidecar"),
    "ter": FormatMetadata(True, True, False, "int16 + SCAL and HeightScale"),
    "exr": FormatMetadata(True, True, True, "float32 Y channel + terrascape attribute"),
    "exr16": FormatMetadata(True, True, False, "half Y channel + terrascape attribute"),
}
LOSSLESS_HINT = ".png (16-bit), .r16, .tif, .r32 or .npy"


class MetadataLossWarning(UserWarning):
    """A heightmap was written in a format that loses its world units or spacing."""


def metadata_loss(key: str) -> str | None:
    """What writing as format ``key`` (``"bmp"``, ``"png8"``, …) loses, or ``None``."""
    keeps = WRITE_METADATA[key]
    if not keeps.world_units:
        return (f"an 8-bit preview: heights are normalised to 0…1 (256 levels) and the "
                f"spacing is not stored; for a heightmap that reads back in world units use "
                f"{LOSSLESS_HINT}")
    if key == "png8":
        return (f"8-bit: heights are quantised to 256 levels; for full precision use "
                f"{LOSSLESS_HINT}")
    return None


READ_EXTENSIONS: tuple[str, ...] = tuple(e for e, (r, _w, _d) in FORMATS.items() if r)
WRITE_EXTENSIONS: tuple[str, ...] = tuple(e for e, (_r, w, _d) in FORMATS.items() if w)

#: ``format=`` names accepted by :func:`write_heightmap` (extension names without the dot
#: also work).
WRITE_FORMAT_NAMES: dict[str, Callable[..., Path]] = {
    "png": write_png16,
    "png16": write_png16,
    "png8": write_preview,
    "bmp": write_preview,
    "r16": write_raw16,
    "raw": write_raw16,
    "r32": write_raw32,
    "tif": write_geotiff,
    "tiff": write_geotiff,
    "cog": write_cog,
    "npy": write_npy,
    "ter": write_terragen,
    "exr": write_exr,
    "exr16": write_exr_half,
}


def formats_help(*, write: bool = False) -> str:
    """One-line list of supported extensions, for CLI help texts."""
    return ", ".join(WRITE_EXTENSIONS if write else READ_EXTENSIONS)


def _extension(path: Path) -> str:
    return path.suffix.lower()


def read_heightmap(
    path: str | os.PathLike,
    *,
    size: int | tuple[int, int] | None = None,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a heightmap file, choosing the reader by extension.

    Parameters
    ----------
    path
        File with one of :data:`READ_EXTENSIONS`.
    size
        RAW only (``.r16``/``.raw``/``.r32``): square side or ``(cols, rows)``.
    spacing
        Override of the sample spacing ``(dx, dz)`` (or one number for both).
    vertical_scale
        Formats without height units (plain images, RAW16 without sidecar): world height of
        the full-scale value (default 1.0). Formats with world units: a multiplier.

    Returns
    -------
    Heightmap
        ``metadata`` holds ``source``, ``format``, ``dtype`` (on disk), ``step``
        (quantisation step in world units, 0 if exact) and ``filled`` (nodata samples filled).

    Raises
    ------
    FileFormatError
        Missing file, unknown extension, truncated/corrupt content.
    InvalidParameterError
        Bad arguments, ``size`` given for a non-RAW file. (NaN/inf samples of float formats
        — GeoTIFF, ``.npy``, ``.r32`` — are nodata: filled with a warning, not refused.)
    """
    p = check_input_path(path)
    ext = _extension(p)
    if ext not in READ_EXTENSIONS:
        raise FileFormatError(
            f"unknown heightmap extension {ext or '(none)'!r} for {p.name}; "
            f"expected one of {formats_help()}"
        )
    kwargs = {"spacing": spacing, "vertical_scale": vertical_scale}
    if ext in (".r16", ".raw", ".r32"):
        reader = read_raw32 if ext == ".r32" else read_raw16
        return reader(p, size=size, **kwargs)
    if size is not None:
        normalise_size(size)  # still report a malformed size as such
        raise InvalidParameterError(
            f"size applies only to headerless RAW files (.r16/.raw/.r32), not {ext}; "
            "the size is read from the file"
        )
    if ext in (".tif", ".tiff"):
        return read_geotiff(p, **kwargs)
    if ext == ".npy":
        return read_npy(p, **kwargs)
    if ext == ".ter":
        return read_terragen(p, **kwargs)
    if ext == ".exr":
        return read_exr(p, **kwargs)
    return read_image(p, **kwargs)


def write_heightmap(
    heightmap: Heightmap,
    path: str | os.PathLike,
    *,
    force: bool = False,
    format: str | None = None,
) -> Path:
    """Write ``heightmap`` atomically, choosing the writer by extension or ``format``.

    ``.png`` → 16-bit PNG with a terrascape chunk (world units restored on read within half
    a step); ``.bmp`` (or ``format="png8"``) → 8-bit normalised preview; ``.r16``/``.raw`` →
    uint16 RAW + ``.json`` sidecar; ``.r32`` → float32 RAW + sidecar; ``.tif`` → float32
    TIFF with ModelPixelScale (``format="cog"``: a Cloud-Optimized GeoTIFF with overviews);
    ``.npy`` → float32 array + ``.npy.json`` sidecar (spacing);
    ``.ter`` → Terragen. What each keeps is :data:`WRITE_METADATA`; a format that loses
    world units or precision (``.bmp``, ``png8``) gives a :class:`MetadataLossWarning`
    naming a lossless one.

    Raises
    ------
    OutputExistsError
        The path (or the RAW sidecar) exists and ``force`` is false.
    FileFormatError
        Unknown extension/format, missing output folder.
    """
    check_heightmap(heightmap)
    p = Path(path)
    if format is not None:
        key = str(format).lower().lstrip(".")
        if key not in WRITE_FORMAT_NAMES:
            raise FileFormatError(
                f"unknown output format {format!r}; expected one of {', '.join(WRITE_FORMAT_NAMES)}"
            )
        writer = WRITE_FORMAT_NAMES[key]
        # Previews pick the image container from the suffix, so it must agree with format.
        want = {"png8": ".png", "bmp": ".bmp", "exr16": ".exr", "cog": ".tif"}.get(key)
        if want is not None and _extension(p) != want and not (
                want == ".tif" and _extension(p) == ".tiff"):
            raise FileFormatError(f"format {key!r} needs a {want} path, got {p.name!r}")
    else:
        ext = _extension(p)
        if ext not in WRITE_EXTENSIONS:
            raise FileFormatError(
                f"cannot write heightmaps as {ext or '(no extension)'!r} ({p.name}); "
                f"expected one of {formats_help(write=True)}"
            )
        key = ext.lstrip(".")
        writer = WRITE_FORMAT_NAMES[key]
    lost = metadata_loss(key)
    if lost is not None:
        warnings.warn(f"{p.name} is {lost}", MetadataLossWarning, stacklevel=2)
    return writer(heightmap, p, force=force)
