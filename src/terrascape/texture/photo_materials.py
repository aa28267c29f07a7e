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

from terrascape._validate import check_int, check_positive, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.texture._block_percentile import block_percentiles
from terrascape.texture._noise import PeriodicFbm

#: Layer texels per block of rows (the photo layers are synthesised block by block).
_BLOCK_PIXELS = 1 << 16

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


def _periodic_spectrum_at(image: np.ndarray, freqs: np.ndarray) -> np.ndarray:
    """DFT coefficients ``P[a, b]`` (``a, b`` in ``freqs``, indices mod the side) of
    :func:`periodic_component` of a square image, without the full complex spectrum.

    ``P = Û − V̂ / denom`` (Moisan 2011): ``Û`` comes from the real FFT of the image (the
    other half by Hermitian symmetry) and the border-jump image ``v`` has a closed-form DFT,
    ``V̂[a, b] = (1 − e^{2πia/m}) D_r[b] + D_c[a] (1 − e^{2πib/n})`` with ``D_r``, ``D_c``
    the 1-D DFTs of the jumps across the top/bottom and left/right borders.
    """
    u = np.asarray(image, dtype=np.float64)
    m, n = u.shape
    half = np.fft.rfft2(u)
    jump_rows = np.fft.fft(u[-1, :] - u[0, :])
    jump_cols = np.fft.fft(u[:, -1] - u[:, 0])
    b = np.mod(freqs, n)[None, :]
    direct = b <= n // 2
    spectrum = np.empty((len(freqs), len(freqs)), dtype=complex)
    step = max(1, _BLOCK_PIXELS // (4 * max(1, len(freqs))))  # rows of a few small temporaries
    for r0 in range(0, len(freqs), step):
        a = np.mod(freqs[r0:r0 + step], m)[:, None]
        block = np.where(direct, half[a, np.minimum(b, n // 2)],
                         np.conj(half[(-a) % m, np.minimum((-b) % n, n // 2)]))
        smooth = ((1.0 - np.exp(2j * np.pi * a / m)) * jump_rows[b]
                  + jump_cols[a] * (1.0 - np.exp(2j * np.pi * b / n)))
        denom = 2.0 * np.cos(2.0 * np.pi * a / m) + 2.0 * np.cos(2.0 * np.pi * b / n) - 4.0
        smooth = np.where((a == 0) & (b == 0), 0.0,
                          smooth / np.where(denom == 0.0, 1.0, denom))
        spectrum[r0:r0 + step] = block - smooth
    return spectrum


def _wrapped_gaussian_response(sigma: float, freqs: np.ndarray, size: int) -> np.ndarray:
    """What ``scipy.ndimage.gaussian_filter1d(·, sigma, mode="grid-wrap")`` does to the
    integer frequencies ``freqs`` of a ``size``-periodic signal: the DFT of its kernel (same
    radius and weights), wrapped around the period. A circular correlation is exactly a
    product in the frequency domain, so filtering the spectrum equals filtering the pixels."""
    radius = int(4.0 * float(sigma) + 0.5)
    x = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 / (sigma * sigma) * x**2)
    weights /= weights.sum()
    wrapped = np.bincount(np.mod(x, size), weights=weights, minlength=size)
    return np.fft.fft(wrapped).real[np.mod(freqs, size)]  # an even kernel: a real response


class _PhotoLayerHeight:
    """A photo layer's detail height (before its contrast normalisation) row by row.

    The photo's periodic component, magnified or repeated (``zoom``) and resampled to the
    layer's size by Fourier interpolation, then high-passed (a wrapped Gaussian of σ = size/8
    removes the photo's illumination gradient, which would repeat with every tile) and
    blurred against grain; plus the procedural fBm. The resampled photo is band-limited, so
    all of it is a small block of Fourier coefficients: the filters act on those, and a block
    of rows is a product of that block with the rows' phases. The peak memory is the block and
    one block of rows, not the layer's float64 image and its full complex spectrum.
    """

    def __init__(self, name: str, size: int, seed: int, *, keep_whole: bool = False) -> None:
        rec = _RECIPES[name]
        self.size = size
        self.recipe = rec
        rng = np.random.default_rng(np.random.SeedSequence([seed, MATERIAL_LAYERS.index(name),
                                                            7]))
        photo = _photo(rec.photo)
        side = photo.shape[0]
        crop = round(min(side, side / rec.zoom))
        if rec.zoom < 1.0:
            # The photo repeated reps × reps times: its DFT is the photo's, reps² times
            # larger, on every reps-th frequency, and zero in between.
            reps = int(np.ceil(1.0 / rec.zoom))
            m = side * reps
        else:
            reps = 1
            photo = photo[:crop, :crop]
            m = crop
        # Fourier resize to size²: the centred k × k block of the m² spectrum; when it is cut
        # (k < m) its first row and column are the unpaired Nyquist frequency: dropped.
        k = min(m, size)
        freqs = np.arange(k) - k // 2
        keep = np.ones(k, dtype=bool)
        if k < m:
            keep[0] = False
        keep &= freqs % reps == 0
        f = freqs[keep]
        block = _periodic_spectrum_at(photo, f // reps)
        del photo
        if reps > 1:
            block *= float(reps * reps)
        response = 1.0 - np.outer(*(2 * [_wrapped_gaussian_response(size / 8.0, f, size)]))
        if rec.blur > 0.0:
            blur = _wrapped_gaussian_response(rec.blur, f, size)
            response *= np.outer(blur, blur)
        block *= response
        del response
        # Transform along x now (rows of the block padded to the layer's width), a few rows
        # at a time: a block of output rows is then Re(phase(rows) @ along_x). The scale is
        # the resize's size²/m² times the inverse DFT's 1/size².
        self._real = np.empty((len(f), size))
        self._imag = np.empty((len(f), size))
        step = max(1, _BLOCK_PIXELS // size)
        for r0 in range(0, len(f), step):
            padded = np.zeros((min(len(f), r0 + step) - r0, size), dtype=complex)
            padded[:, f % size] = block[r0:r0 + step]
            along_x = np.fft.ifft(padded, axis=1)
            along_x *= size / float(m * m)
            self._real[r0:r0 + step] = along_x.real
            self._imag[r0:r0 + step] = along_x.imag
        del block
        self._freqs = f
        self._noise = (PeriodicFbm(size, (4, 4), rng, octaves=5, gain=0.55)
                       if rec.noise > 0.0 else None)
        self._ridged = (PeriodicFbm(size, (3, 3), rng, octaves=3, ridged=True)
                        if rec.ridged > 0.0 else None)
        self._whole: tuple[np.ndarray | None, ...] | None = None
        if keep_whole:
            self._keep_whole()
        # Standard deviations of the three images over the whole layer (one pass of sums
        # and sums of squares, block by block).
        n = float(size * size)
        sums = np.zeros((3, 2))
        for z0, z1 in self.blocks():
            for i, part in enumerate(self._parts(z0, z1)):
                if part is not None:
                    sums[i] += float(part.sum()), float(np.square(part).sum())
        mean = sums[:, 0] / n
        std = np.sqrt(np.maximum(sums[:, 1] / n - mean * mean, 0.0))
        self._stds = [max(float(v), 1e-9) for v in std]

    def blocks(self) -> list[tuple[int, int]]:
        step = max(1, min(self.size, _BLOCK_PIXELS // self.size))
        return [(z0, min(self.size, z0 + step)) for z0 in range(0, self.size, step)]

    def _keep_whole(self) -> None:
        # The images computed once and kept (the whole layer is wanted anyway: faster than
        # recomputing its blocks in every pass, with the same values block for block).
        parts = [np.empty((self.size, self.size)) if p is not None else None
                 for p in self._parts(0, 1)]
        for z0, z1 in self.blocks():
            for whole, part in zip(parts, self._parts(z0, z1), strict=True):
                if whole is not None:
                    whole[z0:z1] = part
        self._whole = tuple(parts)

    def _parts(self, z0: int, z1: int) -> tuple[np.ndarray | None, ...]:
        """Rows ``z0:z1`` of the filtered photo, the fBm and the ridged fBm (or None)."""
        if self._whole is not None:
            return tuple(None if w is None else w[z0:z1] for w in self._whole)
        phase = (2.0 * np.pi / self.size) * np.mod(np.outer(np.arange(z0, z1), self._freqs),
                                                   self.size)
        photo = np.cos(phase) @ self._real - np.sin(phase) @ self._imag
        return (photo,
                None if self._noise is None else self._noise.rows(z0, z1),
                None if self._ridged is None else self._ridged.rows(z0, z1))

    def rows(self, z0: int, z1: int) -> np.ndarray:
        """Rows ``z0:z1`` of the height, float64 ``(z1 - z0, size)``."""
        rec = self.recipe
        photo, noise, ridged = self._parts(z0, z1)
        h = photo / self._stds[0]
        if noise is not None:
            h = h + rec.noise * noise / self._stds[1]
        if ridged is not None:
            h = h - rec.ridged * np.clip(ridged, 0.0, 1.0) ** 4 / self._stds[2]
        return h


class _NormalisedRows:
    """A layer's height rows scaled to [0, 1] by the whole layer's 1st/99th percentiles."""

    def __init__(self, height: _PhotoLayerHeight) -> None:
        self.height = height
        found = block_percentiles(
            lambda: (height.rows(z0, z1) for z0, z1 in height.blocks()), [1.0, 99.0])
        self.lo, self.hi = found if found is not None else (0.0, 0.0)

    def rows(self, z0: int, z1: int) -> np.ndarray:
        h = self.height.rows(z0, z1)
        if not self.hi > self.lo:
            return np.full_like(h, 0.5)
        return np.clip(0.02 + 0.96 * (h - self.lo) / (self.hi - self.lo), 0.0, 1.0)


def _layer_height(name: str, size: int, seed: int) -> np.ndarray:
    """The whole normalised detail height of a layer, float64 ``(size, size)``."""
    layer = _NormalisedRows(_PhotoLayerHeight(name, size, seed, keep_whole=True))
    out = np.empty((size, size))
    for z0, z1 in layer.height.blocks():
        out[z0:z1] = layer.rows(z0, z1)
    return out


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
    size = _check_size(size)
    make_rng(seed)  # validates the seed
    return _cached_layers(size, int(seed))


def layer_spectrum_bytes(size: int) -> float:
    """Memory a photo layer of ``size``² holds besides its image: its block of Fourier
    coefficients (at most 512 frequencies a side, the source photos' size) and the block
    transformed along x (complex128: 16 bytes each), the largest of the layer recipes."""
    k = min(512, int(size))
    return 16.0 * k * (k + int(size))


def _check_size(size: int) -> int:
    size = check_int(size, "material size", minimum=16, maximum=2048)
    if size & (size - 1):
        raise InvalidParameterError(f"material size must be a power of two, got {size}")
    return size


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
    """One photo material's albedo, ``uint8 (size, size, 3)``, tiling seamlessly.

    The same texels as the layer of :func:`photo_material_layers`, made alone and in blocks
    of rows (not cached), so the peak is a few times the image, not the whole layer set.
    """
    if not isinstance(name, str) or name.lower() not in MATERIAL_LAYERS:
        raise InvalidParameterError(
            f"unknown photo material {name!r}; expected one of {', '.join(MATERIAL_LAYERS)}"
        )
    size = _check_size(size)
    make_rng(seed)
    key = name.lower()
    layer = _NormalisedRows(_PhotoLayerHeight(key, size, int(seed)))
    out = np.empty((size, size, 3), dtype=np.uint8)
    for z0, z1 in layer.height.blocks():
        out[z0:z1] = np.rint(_albedo(key, layer.rows(z0, z1))).clip(0, 255)
    return out


__all__ = [
    "MATERIAL_LAYERS",
    "MaterialLayers",
    "detail_normal_height",
    "detail_normals",
    "layer_spectrum_bytes",
    "periodic_component",
    "photo_material",
    "photo_material_layers",
]
