"""Terrain material layers from real photographs: albedo, detail height and detail normals.

scikit-image ships greyscale photographs released under CC0 (public-domain dedication):
``skimage.data.grass()`` (DeviantArt "Grass 01", CC0) and ``skimage.data.gravel()``
(CC0Textures "Gravel04", CC0). Each material layer is made from one of them:

1. the photo's luminance is made **periodic** with the periodic-plus-smooth decomposition
   (Moisan 2011): the smooth component, the part of the image that differs between opposite
   borders, is removed, so the texture wraps without a seam while its interior detail stays;
2. large-scale illumination (a sunlit corner, vignetting) is removed by a wrapped Gaussian
   high-pass, and the contrast is normalised: otherwise every repeat of the texture carries
   the same bright/dark blob, which is what makes tiling visible from afar;
3. the result is the layer's **detail height** (bright = high, as in
   :mod:`terrascape.lighting.height_from_image`), its **albedo** is the height colourised
   with the material's tint ramp (greyscale photo → colour), and its **detail normal map**
   is the wrapped central-difference normal of the height.

The photos are not periodic and their interiors still repeat if tiled plainly; the renderer
and the CPU texture sample them through :mod:`terrascape.texture.hextile`, which removes the
repetition. Everything is cached per ``(size, seed)``.

References
----------
.. [1] L. Moisan, "Periodic plus smooth image decomposition", Journal of Mathematical
   Imaging and Vision 39(2), 2011, 161–179.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from terrascape._validate import check_int, check_positive, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.texture._noise import periodic_fbm

#: Material layers in layer order (index = texture-array layer and weight channel).
MATERIAL_LAYERS: tuple[str, ...] = (
    "grass", "meadow", "rock", "scree", "sediment", "snow", "water",
)


@dataclass(frozen=True)
class _Recipe:
    photo: str            # skimage.data function
    zoom: float           # > 1: photo features larger (a crop magnified), < 1: smaller (tiled)
    blur: float           # Gaussian sigma (pixels of the output) against photo grain
    noise: float          # weight of a procedural periodic fBm mixed into the height
    ridged: float         # weight of ridged fBm (cracks, strata)
    dark: tuple[int, int, int]
    light: tuple[int, int, int]
    bump: float           # detail normal strength: height units per texel


_RECIPES: dict[str, _Recipe] = {
    "grass": _Recipe("grass", 1.0, 0.0, 0.25, 0.0, (38, 62, 22), (120, 150, 62), 2.0),
    "meadow": _Recipe("grass", 0.75, 0.0, 0.3, 0.0, (92, 90, 42), (178, 168, 100), 2.0),
    "rock": _Recipe("gravel", 2.0, 1.0, 0.45, 0.35, (70, 66, 62), (168, 160, 150), 5.0),
    "scree": _Recipe("gravel", 1.0, 0.0, 0.1, 0.0, (84, 80, 74), (176, 168, 156), 4.0),
    "sediment": _Recipe("grass", 1.0, 1.5, 0.5, 0.0, (112, 96, 70), (190, 170, 130), 1.5),
    "snow": _Recipe("gravel", 2.0, 3.0, 0.6, 0.0, (200, 210, 226), (250, 251, 255), 1.0),
    "water": _Recipe("gravel", 2.0, 6.0, 0.8, 0.0, (22, 52, 78), (46, 88, 112), 0.3),
}


def periodic_component(image: np.ndarray) -> np.ndarray:
    """Moisan's periodic component of a 2-D image (float64, same shape): the image minus
    the smooth component that carries its border discontinuities, so it tiles seamlessly.

    ``ŝ(q, r) = v̂(q, r) / (2 cos(2πq/M) + 2 cos(2πr/N) − 4)`` with ``v`` the border jumps
    (``ŝ(0, 0) = 0``: the mean is kept).

    References
    ----------
    .. [1] L. Moisan, "Periodic plus smooth image decomposition", JMIV 39(2), 2011.
    """
    u = np.asarray(image, dtype=np.float64)
    if u.ndim != 2 or min(u.shape) < 2:
        raise InvalidParameterError(f"expected a 2-D image of at least 2×2, got {u.shape}")
    if not np.isfinite(u).all():
        raise InvalidParameterError("image contains NaN/infinite values")
    m, n = u.shape
    v = np.zeros_like(u)
    v[0, :] += u[-1, :] - u[0, :]
    v[-1, :] += u[0, :] - u[-1, :]
    v[:, 0] += u[:, -1] - u[:, 0]
    v[:, -1] += u[:, 0] - u[:, -1]
    q = np.arange(m)[:, None]
    r = np.arange(n)[None, :]
    denom = 2.0 * np.cos(2.0 * np.pi * q / m) + 2.0 * np.cos(2.0 * np.pi * r / n) - 4.0
    denom[0, 0] = 1.0
    s_hat = np.fft.fft2(v) / denom
    s_hat[0, 0] = 0.0
    return u - np.real(np.fft.ifft2(s_hat))


def _photo(name: str) -> np.ndarray:
    import skimage.data

    return np.asarray(getattr(skimage.data, name)(), dtype=np.float64) / 255.0


def _zoomed(photo: np.ndarray, size: int, zoom: float) -> np.ndarray:
    """A ``size``² periodic image showing the photo's features ``zoom`` times larger."""
    # The crop that, resampled to ``size``, gives the requested magnification relative to the
    # photo shown at 512 px per ``size`` px (zoom 1: the whole photo).
    side = photo.shape[0]
    crop = round(min(side, side / zoom))
    tile = periodic_component(photo[:crop, :crop])
    if zoom < 1.0:
        reps = int(np.ceil(1.0 / zoom))
        tile = periodic_component(photo)
        tile = np.tile(tile, (reps, reps))
    # Periodic resampling: Fourier interpolation keeps the wrap exact.
    return _fourier_resize(tile, size)


def _fourier_resize(image: np.ndarray, size: int) -> np.ndarray:
    """Resample a periodic image to ``size``² by truncating/zero-padding its spectrum."""
    m = image.shape[0]
    spec = np.fft.fftshift(np.fft.fft2(image))
    out = np.zeros((size, size), dtype=complex)
    k = min(m, size)
    so, si = (size - k) // 2, (m - k) // 2
    out[so:so + k, so:so + k] = spec[si:si + k, si:si + k]
    if k < m:
        # The kept Nyquist row/column has no conjugate partner: drop it (it would alias).
        out[so, :] = 0.0
        out[:, so] = 0.0
    return np.real(np.fft.ifft2(np.fft.ifftshift(out))) * (size * size) / (m * m)


def _normalise(h: np.ndarray) -> np.ndarray:
    """Zero mean, robust unit range → ``[0, 1]`` (1st/99th percentiles at 0.02/0.98)."""
    lo, hi = np.percentile(h, [1.0, 99.0])
    if not hi > lo:
        return np.full_like(h, 0.5)
    return np.clip(0.02 + 0.96 * (h - lo) / (hi - lo), 0.0, 1.0)


def _layer_height(name: str, size: int, seed: int) -> np.ndarray:
    rec = _RECIPES[name]
    rng = np.random.default_rng(np.random.SeedSequence([seed, MATERIAL_LAYERS.index(name), 7]))
    base = _zoomed(_photo(rec.photo), size, rec.zoom)
    # Wrapped high-pass ("grid-wrap" is scipy's exactly periodic mode): remove the photo's
    # illumination gradient (it would repeat with every tile).
    base = base - ndimage.gaussian_filter(base, size / 8.0, mode="grid-wrap")
    if rec.blur > 0.0:
        base = ndimage.gaussian_filter(base, rec.blur, mode="grid-wrap")
    base /= max(float(base.std()), 1e-9)
    h = base
    if rec.noise > 0.0:
        n = periodic_fbm(size, (4, 4), rng, octaves=5, gain=0.55)
        h = h + rec.noise * n / max(float(n.std()), 1e-9)
    if rec.ridged > 0.0:
        r = periodic_fbm(size, (3, 3), rng, octaves=3, ridged=True)
        h = h - rec.ridged * np.clip(r, 0.0, 1.0) ** 4 / max(float(r.std()), 1e-9)
    return _normalise(h)


def _albedo(name: str, height: np.ndarray) -> np.ndarray:
    rec = _RECIPES[name]
    dark = np.asarray(rec.dark, dtype=np.float64)
    light = np.asarray(rec.light, dtype=np.float64)
    return dark + (light - dark) * height[..., None]


def detail_normals(height: np.ndarray, strength: float) -> np.ndarray:
    """Tangent-space unit normals ``float32 (H, W, 3)`` of a *periodic* height texture.

    Wrapped central differences (``x`` along columns = +u, ``y`` along rows = +v, ``z`` up,
    as :func:`terrascape.lighting.normals.tangent_space_normals`), so the normal map tiles
    exactly like the height. ``strength`` is height units per texel.
    """
    h = np.asarray(height, dtype=np.float64)
    strength = check_positive(strength, "normal strength", allow_zero=True)
    dx = 0.5 * (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) * strength
    dy = 0.5 * (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) * strength
    n = np.stack([-dx, -dy, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return n.astype(np.float32)


@dataclass(frozen=True)
class MaterialLayers:
    """The photo material set, one layer per :data:`MATERIAL_LAYERS` entry.

    Attributes
    ----------
    albedo
        ``uint8 (L, S, S, 4)``: RGB albedo, A = detail height (for height-based blending).
    normals
        ``uint8 (L, S, S, 4)``: RGB = tangent-space normal ``n·0.5 + 0.5``, A = height.
    names
        Layer names, :data:`MATERIAL_LAYERS`.
    """

    albedo: np.ndarray
    normals: np.ndarray
    names: tuple[str, ...] = MATERIAL_LAYERS


@functools.lru_cache(maxsize=8)
def _cached_layers(size: int, seed: int) -> MaterialLayers:
    albedo = np.empty((len(MATERIAL_LAYERS), size, size, 4), dtype=np.uint8)
    normals = np.empty_like(albedo)
    for k, name in enumerate(MATERIAL_LAYERS):
        h = _layer_height(name, size, seed)
        a = _albedo(name, h)
        # Strength in height units per texel: a recipe's bump is set for 256-px layers.
        n = detail_normals(h, _RECIPES[name].bump * size / 256.0)
        code = np.rint(h * 255.0).clip(0, 255).astype(np.uint8)
        albedo[k, ..., :3] = np.rint(a).clip(0, 255)
        albedo[k, ..., 3] = code
        normals[k, ..., :3] = np.rint((n * 0.5 + 0.5) * 255.0).clip(0, 255)
        normals[k, ..., 3] = code
    albedo.flags.writeable = False
    normals.flags.writeable = False
    return MaterialLayers(albedo, normals)


def photo_material_layers(size: int = 256, *, seed: int = 0) -> MaterialLayers:
    """Every photo material layer at ``size``² (cached; arrays are read-only).

    Parameters
    ----------
    size
        Side in pixels, a power of two from 16 to 2048 (mip chains stay exact).
    seed
        Seeds the procedural noise mixed into some layers (rock cracks, snow drifts).

    Returns
    -------
    MaterialLayers
    """
    size = check_int(size, "material size", minimum=16, maximum=2048)
    if size & (size - 1):
        raise InvalidParameterError(f"material size must be a power of two, got {size}")
    make_rng(seed)  # validates the seed
    return _cached_layers(size, int(seed))


def detail_normal_height(name: str = "rock", size: int = 256, *, seed: int = 0,
                         strength: float = 1.0) -> np.ndarray:
    """A photo material's detail normal map with its height, ``uint8 (size, size, 4)``.

    RGB = tangent-space normal ``n·0.5 + 0.5`` (layout of
    :func:`terrascape.lighting.normals.pack_normal_height`), A = detail height; tiles
    seamlessly. ``strength`` scales the material's own relief (1: the layer's normals).
    """
    if not isinstance(name, str) or name.lower() not in MATERIAL_LAYERS:
        raise InvalidParameterError(
            f"unknown photo material {name!r}; expected one of {', '.join(MATERIAL_LAYERS)}"
        )
    strength = check_positive(strength, "strength", allow_zero=True)
    layers = photo_material_layers(size, seed=seed)
    k = MATERIAL_LAYERS.index(name.lower())
    if strength == 1.0:
        return layers.normals[k].copy()
    h = layers.albedo[k, ..., 3].astype(np.float64) / 255.0
    n = detail_normals(h, _RECIPES[name.lower()].bump * size / 256.0 * strength)
    out = np.empty((size, size, 4), dtype=np.uint8)
    out[..., :3] = np.rint((n * 0.5 + 0.5) * 255.0).clip(0, 255)
    out[..., 3] = layers.albedo[k, ..., 3]
    return out


def photo_material(name: str, size: int = 256, *, seed: int = 0) -> np.ndarray:
    """One photo material's albedo, ``uint8 (size, size, 3)``, tiling seamlessly."""
    if not isinstance(name, str) or name.lower() not in MATERIAL_LAYERS:
        raise InvalidParameterError(
            f"unknown photo material {name!r}; expected one of {', '.join(MATERIAL_LAYERS)}"
        )
    layers = photo_material_layers(size, seed=seed)
    return layers.albedo[MATERIAL_LAYERS.index(name.lower()), ..., :3].copy()


__all__ = [
    "MATERIAL_LAYERS",
    "MaterialLayers",
    "detail_normal_height",
    "detail_normals",
    "periodic_component",
    "photo_material",
    "photo_material_layers",
]
