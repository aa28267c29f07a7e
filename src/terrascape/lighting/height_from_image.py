"""Approximate a heightmap from a colour photo (Janković 2010 §2.7).

Janković 2010 §2.7: height maps of cities are generally unavailable, so the author used "a rough
approximation of the height map by a specular (mirror) lighting filter" (Figures 42–43):
brightness stands in for height — lit roofs and ridges are bright, streets and gullies
dark. This module implements that approximation on the photo's luminance:

1. luma ``Y' = 0.299 R + 0.587 G + 0.114 B`` on the stored (gamma-encoded) values
   (:func:`terrascape.io.image.luminance`, the Rec. 601 weights every colour image read in
   terrascape is reduced with);
2. optional ``invert`` (``1 - Y``) for images where dark means high;
3. optional Gaussian blur (``blur_sigma``, pixels) against texture noise;
4. optional high-pass ``Y - G_σ * Y`` (``highpass_sigma``, pixels), which removes
   large-scale illumination gradients (vignetting, a sunlit vs shaded half of the photo)
   that would otherwise become a tilt of the whole terrain;
5. normalisation to ``[0, 1]``;
6. the *specular* response ``h = Y^contrast``: like a specular exponent, ``contrast > 1``
   keeps only the bright highlights high, ``contrast < 1`` lifts the mid-tones.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from terrascape._validate import check_positive
from terrascape.errors import InvalidParameterError
from terrascape.filters.smooth import gaussian_filter_in_bands
from terrascape.io.image import luminance

#: Pixels converted at a time: the float64 copies of an RGB block (24 bytes per pixel,
#: twice) stay a few MB instead of 48 bytes per pixel of the whole photo.
_BLOCK_PIXELS = 1 << 16


def _block_rows(rows: int, cols: int) -> int:
    """Rows per block: at most a sixteenth of the image, at most :data:`_BLOCK_PIXELS`."""
    return max(1, min(rows // 16, _BLOCK_PIXELS // max(1, cols)))


def _check_image(img: np.ndarray) -> None:
    """Shape and pixel type of an image array, checked without converting it."""
    if img.ndim not in (2, 3):
        raise InvalidParameterError(
            f"expected an image of shape (H, W), (H, W, 3) or (H, W, 4), got {img.shape}"
        )
    if img.ndim == 3 and img.shape[2] not in (1, 3, 4):
        raise InvalidParameterError(
            f"expected 1, 3 or 4 colour channels, got {img.shape[2]} (shape {img.shape})"
        )
    if img.shape[0] < 2 or img.shape[1] < 2:
        raise InvalidParameterError(f"expected an image of at least 2×2 pixels, got {img.shape}")
    if img.dtype == np.bool_:
        return
    if np.issubdtype(img.dtype, np.integer):
        if img.dtype not in (np.uint8, np.uint16):
            raise InvalidParameterError(
                f"expected uint8, uint16 or float pixels, got dtype {img.dtype}"
            )
        return
    if not np.issubdtype(img.dtype, np.floating):
        raise InvalidParameterError(f"expected numeric pixels, got dtype {img.dtype}")
    step = _block_rows(*img.shape[:2])
    if not all(np.isfinite(img[r:r + step]).all() for r in range(0, img.shape[0], step)):
        raise InvalidParameterError("image contains NaN/infinite pixel values")
    lo, hi = float(img.min()), float(img.max())
    if lo < 0.0 or hi > 1.0:
        raise InvalidParameterError(f"float pixels must be in [0, 1], got [{lo:.4g}, {hi:.4g}]")


def _to_unit_float(img: np.ndarray) -> np.ndarray:
    """A checked image block -> float64 in [0, 1] (a new array)."""
    if np.issubdtype(img.dtype, np.integer):
        return img.astype(np.float64) / float(np.iinfo(img.dtype).max)
    return img.astype(np.float64)


def _brightness(rgb: Any) -> np.ndarray:
    """Luma of an RGB(A) image, or a grey image as is: a new float64 ``(H, W)`` in [0, 1],
    computed over blocks of rows."""
    img = np.asarray(rgb)
    _check_image(img)
    y = np.empty(img.shape[:2], dtype=np.float64)
    step = _block_rows(*img.shape[:2])
    for r0 in range(0, img.shape[0], step):
        block = _to_unit_float(img[r0:r0 + step])
        if block.ndim == 2:
            y[r0:r0 + step] = block
        elif block.shape[2] == 1:
            y[r0:r0 + step] = block[..., 0]
        else:
            y[r0:r0 + step] = luminance(block)  # alpha ignored
    return y


#: Gaussian radius in samples, as :func:`scipy.ndimage.gaussian_filter` truncates it.
_TRUNCATE = 4.0


def _subtract_blur_in_strips(y: np.ndarray, sigma: float) -> None:
    """``y -= G_σ * y`` in place, a strip of rows at a time (mode ``reflect``).

    Each strip's blur is taken over the strip and ``radius`` rows either side (the rows above
    from a copy kept before they were overwritten), which are all the taps of its rows, so
    every value is the one the whole-image filter gives, bit for bit; at the image's first
    and last rows the strip's edge is the image's, reflected the same way. Extra memory: a
    strip with its halo and one halo copy, instead of a second whole image; a radius close to
    the image's height gains nothing and filters the whole image at once.
    """
    rows = y.shape[0]
    radius = int(_TRUNCATE * sigma + 0.5)
    step = max(radius, -(-rows // 8))
    if step + 3 * radius >= rows:
        blurred = np.empty_like(y)
        gaussian_filter_in_bands(y, sigma, blurred, truncate=_TRUNCATE)
        y -= blurred
        return
    above = y[:0].copy()  # original rows [r0 - radius, r0): already overwritten in y
    for r0 in range(0, rows, step):
        r1 = min(rows, r0 + step)
        below = min(rows, r1 + radius)
        strip = np.concatenate((above, y[r0:below]))
        gaussian_filter_in_bands(strip, sigma, strip, truncate=_TRUNCATE)
        top = len(above)
        above = y[max(0, r1 - radius):r1].copy()
        y[r0:r1] -= strip[top:top + r1 - r0]


def height_from_image(
    rgb: Any,
    *,
    blur_sigma: float = 0.0,
    highpass_sigma: float | None = None,
    contrast: float = 1.0,
    invert: bool = False,
) -> np.ndarray:
    """Heightmap approximated from a photo's brightness (Janković 2010 §2.7).

    Parameters
    ----------
    rgb
        ``(H, W)``, ``(H, W, 3)`` or ``(H, W, 4)``; uint8, uint16, or float in [0, 1].
    blur_sigma
        Gaussian blur radius in pixels (0 = none), applied before the high-pass.
    highpass_sigma
        If given (> 0), subtract a Gaussian blur of this radius (pixels): removes shading
        gradients larger than about ``highpass_sigma`` pixels.
    contrast
        Specular exponent ``> 0`` applied to the normalised result (1 = linear).
    invert
        Treat dark as high.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)`` in [0, 1]; all zeros for a uniform image.
    """
    blur = check_positive(blur_sigma, "blur_sigma", allow_zero=True)
    gamma = check_positive(contrast, "contrast")
    hp = None if highpass_sigma is None else check_positive(highpass_sigma, "highpass_sigma")
    y = _brightness(rgb)  # a new array: the steps below work in place
    # Peak: this float64 image (2× the float32 result) and the result (1×) while it is
    # normalised; the blur runs in place and the high-pass in strips of rows, so neither
    # holds a second whole float64 image.
    if invert:
        np.subtract(1.0, y, out=y)
    if blur > 0.0:
        # scipy filters a line at a time through its own line buffers, so the output may be
        # the input (gaussian_filter does the same between its two axes): identical values.
        gaussian_filter_in_bands(y, blur, y)
    if hp is not None:
        _subtract_blur_in_strips(y, hp)
    lo, hi = float(y.min()), float(y.max())
    # Relative threshold: a constant image blurred in float64 is not exactly constant.
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        return np.zeros(y.shape, dtype=np.float32)
    out = np.empty(y.shape, dtype=np.float32)
    step = _block_rows(*y.shape)
    for r0 in range(0, y.shape[0], step):
        block = y[r0:r0 + step]
        block -= lo
        block /= hi - lo
        if gamma != 1.0:
            block **= gamma
        np.clip(block, 0.0, 1.0, out=block)
        out[r0:r0 + step] = block
    return out


__all__ = ["height_from_image"]
