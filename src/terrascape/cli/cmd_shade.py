"""``terrascape normalmap | heightfromimage | shade``.

Thin layer over :mod:`terrascape.lighting`: read, compute, write a PNG atomically.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import typer

from terrascape.cli.app import MAX_MEMORY, app, out, timed, use_max_memory
from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import atomic_output, check_output_path

_FORCE = typer.Option(False, "--force", help="Overwrite the output file if it exists.")
_QUIET = typer.Option(False, "--quiet", "-q", help="No timing lines.")


# --- helpers -----------------------------------------------------------------------------------
def _require_png(path: Path) -> None:
    if path.suffix.lower() != ".png":
        raise InvalidParameterError(
            f"output must be a .png file, got {path.name!r} (suffix {path.suffix or 'none'})"
        )


def _read_heightmap(path: Path):
    from terrascape.io import read_heightmap

    try:
        return read_heightmap(path)
    except TerrascapeError:
        raise
    except (OSError, ValueError) as exc:  # a reader's own low-level error: still a bad file
        raise FileFormatError(f"cannot read heightmap {path}: {exc}") from exc


def _check_memory(command: str, rows: int, cols: int, max_memory: str | None, *,
                  extra: float = 0.0, hint: str = "use a smaller map (or raise --max-memory)"
                  ) -> None:
    from terrascape.memory import check_grid

    use_max_memory(max_memory)
    check_grid(command, rows, cols, extra=extra, hint=hint)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)


def encode_png_rgba16(rgba: np.ndarray) -> bytes:
    """A 16-bit RGBA PNG (colour type 6, bit depth 16) — Pillow cannot write this mode.

    Scanlines use filter type 0 (None); samples are big-endian as the PNG spec requires.
    """
    a = np.asarray(rgba)
    if a.ndim != 3 or a.shape[2] != 4 or a.dtype != np.uint16:
        raise InvalidParameterError(f"expected uint16 (rows, cols, 4), got {a.dtype} {a.shape}")
    rows, cols = a.shape[:2]
    lines = a.astype(">u2").reshape(rows, cols * 8 // 2).view(np.uint8).reshape(rows, cols * 8)
    raw = np.concatenate([np.zeros((rows, 1), np.uint8), lines], axis=1).tobytes()
    ihdr = struct.pack(">IIBBBBB", cols, rows, 16, 6, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + _png_chunk(b"IHDR", ihdr)
        + _png_chunk(b"IDAT", zlib.compress(raw, 6))
        + _png_chunk(b"IEND", b"")
    )


def _write_rgba(rgba: np.ndarray, path: Path, force: bool) -> None:
    from PIL import Image

    with atomic_output(path, force=force) as tmp:
        if rgba.dtype == np.uint16:
            tmp.write_bytes(encode_png_rgba16(rgba))
        else:
            Image.fromarray(rgba).save(tmp, format="PNG")


def _read_photo(path: Path) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise FileFormatError(f"image not found: {path}")
    try:
        with Image.open(path) as im:
            im.load()
            if im.mode in ("I;16", "I;16B", "I;16L"):
                return np.array(im, dtype=np.uint16)
            if im.mode in ("I", "F"):
                arr = np.array(im, dtype=np.float64)
                lo, hi = float(arr.min()), float(arr.max())
                return (arr - lo) / (hi - lo) if hi > lo else np.zeros_like(arr)
            return np.array(im.convert("RGBA" if "A" in im.mode else "RGB"), dtype=np.uint8)
    except UnidentifiedImageError:
        raise FileFormatError(f"{path} is not an image Pillow can read") from None
    except Image.DecompressionBombError as exc:
        raise FileFormatError(
            f"cannot read image {path}: {exc} (refused as a possible decompression bomb)"
        ) from None
    except (OSError, SyntaxError, ValueError, EOFError) as exc:
        raise FileFormatError(f"cannot read image {path}: {exc}") from None


# --- commands ----------------------------------------------------------------------------------
@app.command("normalmap")
def normalmap_cmd(
    heightmap: Path = typer.Argument(..., help="Input heightmap (any format terrascape reads)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output RGBA .png file."),
    height_scale: float = typer.Option(
        1.0, "--height-scale", help="Vertical exaggeration of the heights (unitless factor)."
    ),
    bits: int = typer.Option(8, "--bits", help="Bits per channel: 8 or 16."),
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Write the packed normal + height texture: RGB = tangent-space normal, A = height."""
    from terrascape.lighting import pack_normal_height

    _require_png(output)
    if bits not in (8, 16):
        raise InvalidParameterError(f"--bits must be 8 or 16, got {bits}")
    if not (np.isfinite(height_scale) and 0 < abs(height_scale) <= 1e6):
        # Beyond ~1e6 every slope is so steep that the normals are horizontal to float32
        # precision (and inf·0 gives NaN): the texture would be flat grey, silently.
        raise InvalidParameterError(
            f"--height-scale must be a non-zero factor with |F| <= 1e6, got {height_scale!r}; "
            "larger exaggerations make every normal horizontal"
        )
    check_output_path(output, force=force)
    with timed("read", quiet=quiet):
        hm = _read_heightmap(heightmap)
    _check_memory("normalmap", hm.rows, hm.cols, max_memory)
    with timed("normals", quiet=quiet):
        packed = pack_normal_height(hm, height_scale=height_scale, bits=bits)
    with timed("write", quiet=quiet):
        _write_rgba(packed, output, force)
    if not quiet:
        out.print(f"{output}  {hm.cols}×{hm.rows} RGBA {bits}-bit (normal + height)")


@app.command("heightfromimage")
def heightfromimage_cmd(
    image: Path = typer.Argument(..., help="Colour or grey photo (PNG, JPEG, BMP, ...)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output 16-bit grey heightmap .png."),
    blur: float = typer.Option(0.0, "--blur", help="Gaussian blur sigma in pixels (0 = none)."),
    highpass: float = typer.Option(
        0.0, "--highpass",
        help="High-pass sigma in pixels: removes shading gradients larger than this (0 = off).",
    ),
    contrast: float = typer.Option(
        1.0, "--contrast", help="Specular exponent on the normalised height (>0; 1 = linear)."
    ),
    invert: bool = typer.Option(False, "--invert", help="Dark means high."),
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Approximate a heightmap from a photo's brightness (bright = high)."""
    from terrascape.io import write_png16
    from terrascape.lighting import height_from_image

    _require_png(output)
    check_output_path(output, force=force)
    if highpass < 0:
        raise InvalidParameterError(f"--highpass must be >= 0 pixels, got {highpass}")
    with timed("read", quiet=quiet):
        rgb = _read_photo(image)
    from terrascape.memory import gaussian_kernel_bytes

    kernels = max(gaussian_kernel_bytes(blur) if blur > 0 else 0.0,
                  gaussian_kernel_bytes(highpass) if highpass > 0 else 0.0)
    _check_memory("heightfromimage", rgb.shape[0], rgb.shape[1], max_memory, extra=kernels,
                  hint="a blur or high-pass much wider than the image only averages it: use a "
                       "smaller --blur/--highpass (or raise --max-memory)")
    with timed("height", quiet=quiet):
        h = height_from_image(
            rgb, blur_sigma=blur, highpass_sigma=highpass or None, contrast=contrast,
            invert=invert,
        )
    with timed("write", quiet=quiet):
        write_png16(Heightmap(h), output, force=force)
    if not quiet:
        out.print(f"{output}  {h.shape[1]}×{h.shape[0]} 16-bit heights in [0, 1]")


@app.command("shade")
def shade_cmd(
    heightmap: Path = typer.Argument(..., help="Input heightmap (any format terrascape reads)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output 8-bit grey lightmap .png."),
    sun: str = typer.Option(
        "135,45", "--sun",
        help="Sun direction AZ,EL in degrees: azimuth clockwise from north (90 = east), "
             "elevation above the horizon in (0, 90]."),
    sun_azimuth: float = typer.Option(
        None, "--sun-azimuth", hidden=True, help="Deprecated: use --sun AZ,EL."),
    sun_elevation: float = typer.Option(
        None, "--sun-elevation", hidden=True, help="Deprecated: use --sun AZ,EL."),
    lighting: str = typer.Option(
        "daylight", "--lighting",
        help="Light model: daylight (sun + blue sky + bounce, soft shadows, filmic tone map) "
        "or classic (ambient + 0.5·(1 + N·L) where lit, ambient in shadow).",
    ),
    color: bool = typer.Option(
        False, "--color", help="Daylight: write an RGB lightmap (blue sky light in shadows)."
    ),
    turbidity: float = typer.Option(
        3.0, "--turbidity", help="Daylight: haze of the air, 1.7 (very clear) to 10 (hazy)."
    ),
    exposure: float = typer.Option(
        -1.0, "--exposure", help="Daylight: exposure correction in stops (EV)."
    ),
    ambient: float = typer.Option(0.2, "--ambient", help="Classic model: ambient light in [0, 1]."),
    soft: bool = typer.Option(
        False, "--soft", help="Classic model: soft shadows from the sun's disc (0.27°); the "
        "daylight model's shadows are always soft."
    ),
    no_shadows: bool = typer.Option(False, "--no-shadows", help="Slope shading only."),
    method: str = typer.Option(
        "fast", "--method",
        help="Classic model shadow method: fast (O(n²) sweep) or reference (ray per sample).",
    ),
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Lightmap of the terrain under the sun: the daylight model (default), or ambient +
    0.5·(1 + N·L) where the sun is seen and ambient in shadow (--lighting classic)."""
    import warnings

    from PIL import Image

    from terrascape.cli.parsing import parse_floats
    from terrascape.lighting import lightmap
    from terrascape.lighting.daylight import lighting_model

    sun_az, sun_el = parse_floats(sun, 2, name="--sun AZ,EL")
    if sun_azimuth is not None or sun_elevation is not None:
        warnings.warn("--sun-azimuth/--sun-elevation are deprecated; use --sun AZ,EL "
                      "(as in render and relief)", FutureWarning, stacklevel=2)
        sun_az = sun_az if sun_azimuth is None else sun_azimuth
        sun_el = sun_el if sun_elevation is None else sun_elevation

    _require_png(output)
    if lighting not in ("daylight", "classic", "seed"):
        raise InvalidParameterError(f"--lighting must be daylight or classic, got {lighting!r}")
    lighting = lighting_model(lighting)  # the earlier name "seed" says the new one, once
    if method not in ("fast", "reference"):
        raise InvalidParameterError(f"--method must be 'fast' or 'reference', got {method!r}")
    if lighting == "classic" and color:
        raise InvalidParameterError("--color needs --lighting daylight")
    check_output_path(output, force=force)
    with timed("read", quiet=quiet):
        hm = _read_heightmap(heightmap)
    from terrascape.memory import PEAK_BYTES_PER_SAMPLE

    share = PEAK_BYTES_PER_SAMPLE["shade"] / PEAK_BYTES_PER_SAMPLE["shade daylight"]
    _check_memory("shade" if lighting == "classic" else "shade daylight", hm.rows, hm.cols,
                  max_memory, hint=f"use a smaller map or --lighting classic (about {share:.0%} "
                                   "of the memory), or raise --max-memory")
    with timed("lightmap", quiet=quiet):
        if lighting == "classic":
            light = lightmap(
                hm, sun_az, sun_el, model="classic", ambient=ambient,
                shadows=not no_shadows, soft=soft, method=method,
            )
        else:
            light = lightmap(
                hm, sun_az, sun_el, shadows=not no_shadows, color=color,
                turbidity=turbidity, exposure=exposure,
            )
    mean = float(light.mean())
    light *= np.float32(255.0)  # in place: the 8-bit codes are the only new array
    np.rint(light, out=light)
    codes = light.astype(np.uint8)
    del light
    with timed("write", quiet=quiet), atomic_output(output, force=force) as tmp:
        Image.fromarray(codes).save(tmp, format="PNG")
    if not quiet:
        kind = "RGB" if codes.ndim == 3 else "grey"
        out.print(f"{output}  {hm.cols}×{hm.rows} {lighting} {kind} lightmap, "
                  f"mean {mean:.3f}")
