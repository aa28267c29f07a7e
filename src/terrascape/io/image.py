"""Heightmaps as images: 8/16-bit grayscale PNG/BMP/JPEG in, 16-bit PNG and 8-bit previews out.

A height map "is a special kind of image with one colour channel; black is usually the lowest
height and white the highest", and reading one means "loading integers from
the file and scaling them to the floats used in space". Images carry no
height units, so a plain image gives ``value / full_scale * vertical_scale`` (full scale 255
for 8-bit, 65535 for 16-bit). PNGs written by terrascape carry a ``tEXt`` chunk named
``terrascape`` with the height offset/scale and the sample spacing; reading restores world
units from it to within half a quantisation step.

Colour images are reduced to **Rec. 601 luma** on the stored (gamma-encoded) values,
``Y' = 0.299 R + 0.587 G + 0.114 B`` — the weights of JPEG/JFIF and of Pillow's ``"L"``
conversion, computed here in float so no extra 8-bit rounding happens. Alpha is ignored.

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §2.1.
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.1.
"""

from __future__ import annotations

import os
import struct
import warnings
from pathlib import Path

import numpy as np
from PIL import Image, PngImagePlugin

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io._common import (
    META_KEY,
    check_heightmap,
    check_input_path,
    check_vertical_scale,
    file_metadata,
    meta_json,
    normalise_spacing,
    parse_meta,
    quantise,
)
from terrascape.io.atomic import atomic_output, check_output_path

#: Rec. 601 luma weights for R, G, B.
REC601_LUMA = (0.299, 0.587, 0.114)

_PREVIEW_FORMATS = {".png": "PNG", ".bmp": "BMP"}
#: zlib level of 16-bit height PNGs: against Pillow's default 6, 1.000–1.028× the bytes in
#: 0.36–0.89× the time on the generators' 4097² maps and a real DEM (level 3: up to 1.13×
#: the bytes; ``python scripts/png_compress_levels.py 4097``, docs/benchmarks.md)
PNG16_COMPRESS_LEVEL = 4
_PIL_ERRORS = (
    OSError,
    SyntaxError,
    ValueError,
    EOFError,
    struct.error,
    Image.DecompressionBombError,
)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 601 luma ``0.299 R + 0.587 G + 0.114 B`` of an ``(..., 3+)`` array, float64.

    Extra channels (alpha) are ignored.
    """
    rgb = np.asarray(rgb)
    if rgb.ndim < 1 or rgb.shape[-1] < 3:
        raise InvalidParameterError(f"expected (..., 3) RGB values, got shape {rgb.shape}")
    w = np.asarray(REC601_LUMA, dtype=np.float64)
    return rgb[..., :3].astype(np.float64) @ w


def _image_values(im: Image.Image) -> tuple[np.ndarray, float, str, bool]:
    """``(values float64, full_scale, dtype on disk, is_gray)`` for a loaded Pillow image."""
    mode = im.mode
    if mode in ("I;16", "I;16L", "I;16B", "I;16N"):
        return np.asarray(im).astype(np.float64), 65535.0, "uint16", True
    if mode == "I":  # older Pillow opens 16-bit grayscale PNG as 32-bit "I"
        return np.asarray(im).astype(np.float64), 65535.0, "uint16", True
    if mode == "L":
        return np.asarray(im).astype(np.float64), 255.0, "uint8", True
    if mode == "LA":
        return np.asarray(im)[..., 0].astype(np.float64), 255.0, "uint8 (gray+alpha)", True
    if mode == "1":
        return np.asarray(im).astype(np.float64), 1.0, "bool", True
    if mode == "F":
        return np.asarray(im).astype(np.float64), 1.0, "float32", True
    if mode in ("P", "PA"):
        rgb = np.asarray(im.convert("RGB"))
        return luminance(rgb), 255.0, "uint8 palette → Rec.601 luma", False
    if mode in ("RGB", "RGBA", "RGBX", "RGBa"):
        return luminance(np.asarray(im)), 255.0, f"uint8 {mode} → Rec.601 luma", False
    if mode in ("CMYK", "YCbCr", "LAB", "HSV"):
        rgb = np.asarray(im.convert("RGB"))
        return luminance(rgb), 255.0, f"uint8 {mode} → Rec.601 luma", False
    raise FileFormatError(
        f"unsupported image mode {mode!r}; expected grayscale (8/16-bit) or RGB(A)"
    )


def read_image(
    path: str | os.PathLike,
    *,
    spacing: float | tuple[float, float] | None = None,
    vertical_scale: float | None = None,
) -> Heightmap:
    """Read a PNG/BMP/JPEG (or any Pillow-readable image) as a heightmap.

    Parameters
    ----------
    path
        Image file.
    spacing
        Override of the sample spacing ``(dx, dz)``; default: from the terrascape chunk,
        else ``(1, 1)``.
    vertical_scale
        Plain image: world height of full white (default 1.0). Image with a terrascape
        chunk (already world units): a multiplier on the restored heights.

    Raises
    ------
    FileFormatError
        Missing, truncated or corrupt file, unsupported mode, corrupt terrascape chunk.
    """
    p = check_input_path(path)
    spacing = normalise_spacing(spacing)
    vscale = check_vertical_scale(vertical_scale)
    try:
        with Image.open(p) as im:
            im.load()  # decode now so truncation is reported here, not later
            image_format = (im.format or p.suffix.lstrip(".")).lower()
            text = dict(getattr(im, "text", None) or {})
            values, full_scale, dtype, is_gray = _image_values(im)
    except _PIL_ERRORS as exc:
        raise FileFormatError(f"cannot read image {p}: {exc}") from None

    bits = 16 if full_scale == 65535.0 else 8 if full_scale == 255.0 else None
    meta = None
    if META_KEY in text and is_gray:
        meta = parse_meta(text[META_KEY], where=f"PNG text chunk of {p}")
        if meta.get("bits") != bits:
            warnings.warn(
                f"{p}: terrascape chunk says {meta.get('bits')}-bit but the image is "
                f"{bits}-bit; ignoring the chunk (heights are normalised)",
                stacklevel=2,
            )
            meta = None

    if meta is not None:
        scale = float(meta.get("scale", 0.0))
        heights = float(meta.get("offset", 0.0)) + values * scale
        step = scale
        if vscale is not None:
            heights = heights * vscale
            step *= vscale
        file_spacing = meta.get("spacing")
    else:
        if vscale is None:
            warnings.warn(
                f"{p.name} has no height units: heights are normalised to 0…1 and the spacing "
                f"is 1 (give --vertical-scale/--spacing, or keep heightmaps as .png written "
                f"by terrascape, .tif, .r16, .r32 or .npy)",
                stacklevel=2,
            )
        v = 1.0 if vscale is None else vscale
        heights = values * (v / full_scale)
        step = v / full_scale
        file_spacing = None
    sp = spacing or file_spacing or (1.0, 1.0)
    md = file_metadata(p, image_format, dtype, step=step, units_restored=meta is not None)
    return Heightmap(heights.astype(np.float32), sp, md)


def _png_info(record: str) -> PngImagePlugin.PngInfo:
    info = PngImagePlugin.PngInfo()
    info.add_text(META_KEY, record)  # tEXt: plain Latin-1 JSON, readable by any PNG tool
    return info


def write_png16(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write a 16-bit grayscale PNG: ``[min, max]`` → ``[0, 65535]`` plus a terrascape chunk.

    The chunk stores ``offset`` (= min), ``scale`` (= (max − min) / 65535) and ``spacing``, so
    :func:`read_image` restores world heights within ``scale / 2``.
    """
    check_heightmap(heightmap)
    codes, offset, scale = quantise(heightmap.heights, 65535)
    record = meta_json(bits=16, offset=offset, scale=scale, spacing=list(heightmap.spacing))
    with atomic_output(path, force=force) as tmp:
        Image.fromarray(codes).save(tmp, format="PNG", pnginfo=_png_info(record),
                                    compress_level=PNG16_COMPRESS_LEVEL)
    return Path(path)


def write_preview(heightmap: Heightmap, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Write an 8-bit normalised grayscale preview (``.png`` or ``.bmp``).

    ``[min, max]`` → ``[0, 255]``. PNG previews also get the terrascape chunk (8-bit), so
    reading one back gives world heights to within half of (max − min) / 255; BMP has no
    place for it and reads back as ``[0, 1]`` (times ``vertical_scale``).
    """
    check_heightmap(heightmap)
    suffix = Path(path).suffix.lower()
    if suffix not in _PREVIEW_FORMATS:
        raise FileFormatError(
            f"preview must be .png or .bmp, got {Path(path).name!r} (suffix {suffix or 'none'})"
        )
    check_output_path(path, force=force)
    codes, offset, scale = quantise(heightmap.heights, 255)
    im = Image.fromarray(codes)
    with atomic_output(path, force=force) as tmp:
        if suffix == ".png":
            record = meta_json(bits=8, offset=offset, scale=scale, spacing=list(heightmap.spacing))
            im.save(tmp, format="PNG", pnginfo=_png_info(record))
        else:
            im.save(tmp, format=_PREVIEW_FORMATS[suffix])
    return Path(path)
