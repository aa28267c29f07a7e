"""Material textures: procedural built-ins that tile seamlessly, and user images.

The seed (001 §3.1.1) blends one texture per height region; it loads them from files. To
work without any asset, terrascape also generates five built-in materials from seeded
periodic value noise (:mod:`terrascape.texture._noise`), so each tiles exactly: column 0
continues column ``size - 1`` and row 0 continues the last row.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

import numpy as np

from terrascape._validate import check_int, make_rng
from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.texture._noise import PeriodicFbm

BUILTIN_MATERIALS: tuple[str, ...] = ("water", "sand", "grass", "rock", "snow")

TextureSpec = np.ndarray | str | os.PathLike | None


def _lerp_colour(t: np.ndarray, lo: tuple[int, int, int], hi: tuple[int, int, int]) -> np.ndarray:
    lo_a = np.asarray(lo, dtype=np.float64)
    hi_a = np.asarray(hi, dtype=np.float64)
    return lo_a + (hi_a - lo_a) * t[..., None]


def _unit(n: np.ndarray) -> np.ndarray:
    """Map noise in [-1, 1] to [0, 1]."""
    return np.clip(0.5 + 0.5 * n, 0.0, 1.0)


#: Pixels of a material computed at a time: its float64 colour block stays a few MB, not
#: 24 bytes per pixel of the whole texture (plus the temporaries of every step).
_BLOCK_PIXELS = 1 << 16


def _make_material(name: str, size: int, rng: np.random.Generator) -> np.ndarray:
    # Every lattice is drawn first, in the order the layers are listed, then the rows are
    # built block by block with the grain drawn last, block after block: the same draws, in
    # the same order, as building the whole image at once.
    if name == "water":
        # Ripples stretched along X: 4× more lattice cells along Z than along X.
        layers = [PeriodicFbm(size, (2, 8), rng, octaves=4)]
    elif name == "sand":
        layers = [PeriodicFbm(size, (3, 3), rng, octaves=3)]
    elif name in ("grass", "rock"):
        layers = [PeriodicFbm(size, (4, 4), rng, octaves=5, gain=0.55)]
        if name == "rock":
            layers.append(PeriodicFbm(size, (3, 3), rng, octaves=3, ridged=True))
    elif name == "snow":
        layers = [PeriodicFbm(size, (3, 3), rng, octaves=4)]
    else:  # pragma: no cover - guarded by builtin_material
        raise AssertionError(name)
    out = np.empty((size, size, 3), dtype=np.uint8)
    step = max(1, min(size // 16, _BLOCK_PIXELS // size))  # small textures: small blocks
    for z0 in range(0, size, step):
        z1 = min(size, z0 + step)
        noise = [layer.rows(z0, z1) for layer in layers]
        # White per-pixel grain is trivially periodic (every pixel independent), so it keeps
        # the wrap-around seam statistically identical to interior neighbours.
        grain = rng.uniform(-1.0, 1.0, size=(z1 - z0, size))
        out[z0:z1] = _material_colour(name, noise, grain)
    return out


def _material_colour(name: str, noise: list[np.ndarray], grain: np.ndarray) -> np.ndarray:
    """The uint8 colours of a block of rows from its noise layers and grain."""
    if name == "water":
        colour = _lerp_colour(_unit(1.4 * noise[0]), (18, 52, 98), (46, 104, 150))
        colour += 3.0 * grain[..., None]
    elif name == "sand":
        colour = _lerp_colour(_unit(1.2 * noise[0]), (186, 166, 118), (224, 204, 154))
        colour += 10.0 * grain[..., None]
    elif name == "grass":
        colour = _lerp_colour(_unit(1.3 * noise[0]), (48, 92, 30), (104, 146, 56))
        colour += np.stack([6.0 * grain, 12.0 * grain, 4.0 * grain], axis=-1)
    elif name == "rock":
        body, cracks = noise
        colour = _lerp_colour(_unit(1.2 * body), (92, 88, 82), (156, 150, 142))
        # Ridged noise near 1 marks crease lines: darken them for cracks.
        colour *= (1.0 - 0.35 * np.clip(cracks, 0.0, 1.0) ** 6)[..., None]
        colour += 6.0 * grain[..., None]
    else:  # snow
        colour = _lerp_colour(_unit(1.2 * noise[0]), (218, 226, 240), (252, 252, 255))
        colour += 2.5 * grain[..., None]
    return np.clip(np.rint(colour), 0, 255).astype(np.uint8)


@functools.lru_cache(maxsize=64)
def _cached_material(name: str, size: int, seed: int) -> np.ndarray:
    index = BUILTIN_MATERIALS.index(name)
    # One independent stream per (seed, material): changing one material never shifts another.
    rng = np.random.default_rng(np.random.SeedSequence([seed, index]))
    out = _make_material(name, size, rng)
    out.flags.writeable = False
    return out


def builtin_material(name: str, size: int = 256, *, seed: int = 0) -> np.ndarray:
    """A procedural material texture that tiles seamlessly.

    Parameters
    ----------
    name
        One of :data:`BUILTIN_MATERIALS` (``water``, ``sand``, ``grass``, ``rock``, ``snow``).
    size
        Side in pixels (>= 4). Powers of two mip-map exactly; other sizes still tile.
    seed
        Non-negative integer; same seed → same bytes.

    Returns
    -------
    numpy.ndarray
        ``uint8 (size, size, 3)`` RGB.
    """
    if not isinstance(name, str) or name.lower() not in BUILTIN_MATERIALS:
        raise InvalidParameterError(
            f"unknown built-in material {name!r}; expected one of {', '.join(BUILTIN_MATERIALS)}"
        )
    size = check_int(size, "material size", minimum=4, maximum=8192)
    make_rng(seed)  # validates the seed
    return _cached_material(name.lower(), size, int(seed)).copy()


def as_rgb_image(image: Any, *, name: str = "texture") -> np.ndarray:
    """Validate an image array and return it as ``uint8 (H, W, 3)``.

    Accepts ``(H, W)`` grey, ``(H, W, 1)``, ``(H, W, 3)`` RGB or ``(H, W, 4)`` RGBA (alpha is
    dropped), either uint8/uint16 or floats in ``[0, 1]``.
    """
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = arr[..., None]
    if arr.ndim != 3 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise InvalidParameterError(
            f"{name} must be an image array (H, W) or (H, W, C), got shape {arr.shape}"
        )
    channels = arr.shape[2]
    if channels not in (1, 3, 4):
        raise InvalidParameterError(
            f"{name} must have 1 (grey), 3 (RGB) or 4 (RGBA) channels, got {channels}"
        )
    if arr.dtype == np.uint8:
        out = arr
    elif arr.dtype == np.uint16:
        out = (arr.astype(np.uint32) * 255 + 32767) // 65535
    elif np.issubdtype(arr.dtype, np.floating):
        if not np.isfinite(arr).all():
            raise InvalidParameterError(f"{name} contains NaN/infinite values")
        lo, hi = float(arr.min()), float(arr.max())
        if lo < 0.0 or hi > 1.0:
            raise InvalidParameterError(
                f"float {name} values must be in [0, 1], got [{lo:.4g}, {hi:.4g}]"
            )
        out = np.rint(arr * 255.0)
    else:
        raise InvalidParameterError(
            f"{name} must be uint8, uint16 or float in [0, 1], got dtype {arr.dtype}"
        )
    if channels == 1:
        out = np.repeat(out, 3, axis=2)
    elif channels == 4:
        out = out[..., :3]
    return np.ascontiguousarray(out, dtype=np.uint8)


def read_image_rgb(path: str | os.PathLike) -> np.ndarray:
    """Read an image file (PNG, JPEG, BMP, TIFF…) as ``uint8 (H, W, 3)``."""
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    if not p.is_file():
        raise FileFormatError(f"texture file {p} does not exist")
    try:
        with Image.open(p) as img:
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                arr = np.asarray(img, dtype=np.float64)
                return as_rgb_image(np.clip(arr / 65535.0, 0.0, 1.0), name=str(p))
            return np.ascontiguousarray(np.asarray(img.convert("RGB")), dtype=np.uint8)
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(f"{p} is not a readable image file ({exc})") from None


def resize_rgb(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Resize ``uint8 (H, W, 3)`` to ``size = (height, width)``; a no-op when equal.

    Exact power-of-two reductions use 2×2 box means, which keep a seamless texture seamless;
    other sizes use Pillow's Lanczos filter.
    """
    h, w = int(size[0]), int(size[1])
    if image.shape[:2] == (h, w):
        return image
    ih, iw = image.shape[:2]
    if ih % h == 0 and iw % w == 0 and ih // h == iw // w and ((ih // h) & (ih // h - 1)) == 0:
        f = ih // h
        blocks = image.reshape(h, f, w, f, 3).astype(np.float64)
        return np.rint(blocks.mean(axis=(1, 3))).astype(np.uint8)
    from PIL import Image

    return np.asarray(Image.fromarray(image, "RGB").resize((w, h), Image.Resampling.LANCZOS))


def load_texture(spec: TextureSpec, *, default_name: str, size: int, seed: int = 0) -> np.ndarray:
    """Resolve a texture spec to ``uint8 (size, size, 3)``.

    ``None`` → the built-in named ``default_name``; a string naming a built-in → that
    built-in; any other string/path → an image file; an array → validated image.
    """
    if spec is None:
        if default_name.lower() not in BUILTIN_MATERIALS:
            raise InvalidParameterError(
                f"region {default_name!r} has no texture and is not a built-in material "
                f"({', '.join(BUILTIN_MATERIALS)}); give it texture=<array|path|builtin name>"
            )
        return builtin_material(default_name, size, seed=seed)
    if isinstance(spec, str) and spec.lower() in BUILTIN_MATERIALS:
        return builtin_material(spec, size, seed=seed)
    if isinstance(spec, (str, os.PathLike)):
        return resize_rgb(read_image_rgb(spec), (size, size))
    if isinstance(spec, np.ndarray):
        return resize_rgb(as_rgb_image(spec, name=f"texture of region {default_name!r}"),
                          (size, size))
    raise InvalidParameterError(
        f"texture must be an image array, a file path or a built-in name, got {type(spec).__name__}"
    )


__all__ = [
    "BUILTIN_MATERIALS",
    "as_rgb_image",
    "builtin_material",
    "load_texture",
    "read_image_rgb",
    "resize_rgb",
]
