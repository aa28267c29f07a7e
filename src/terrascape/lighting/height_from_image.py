"""Approximate a heightmap from a colour photo (MISSION T6; seed 000 §2.7).

Seed 000 §2.7: height maps of cities are generally unavailable, so the author used "a rough
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
from scipy import ndimage

from terrascape._validate import check_positive
from terrascape.errors import InvalidParameterError
from terrascape.io.image import luminance


def _to_unit_float(rgb: Any) -> np.ndarray:
    """Image array -> float64 ``(H, W)`` or ``(H, W, C)`` in [0, 1], validated."""
    img = np.asarray(rgb)
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
        return img.astype(np.float64)
    if np.issubdtype(img.dtype, np.integer):
        if img.dtype not in (np.uint8, np.uint16):
            raise InvalidParameterError(
                f"expected uint8, uint16 or float pixels, got dtype {img.dtype}"
            )
        return img.astype(np.float64) / float(np.iinfo(img.dtype).max)
    if not np.issubdtype(img.dtype, np.floating):
        raise InvalidParameterError(f"expected numeric pixels, got dtype {img.dtype}")
    out = img.astype(np.float64)
    if not np.isfinite(out).all():
        raise InvalidParameterError("image contains NaN/infinite pixel values")
    if out.min() < 0.0 or out.max() > 1.0:
        raise InvalidParameterError(
            f"float pixels must be in [0, 1], got [{out.min():.4g}, {out.max():.4g}]"
        )
    return out


def _brightness(rgb: Any) -> np.ndarray:
    """Luma of an RGB(A) image, or a grey image as is: float64 ``(H, W)`` in [0, 1]."""
    img = _to_unit_float(rgb)
    if img.ndim == 2:
        return img
    if img.shape[2] == 1:
        return img[..., 0]
    return luminance(img)  # alpha ignored


def height_from_image(
    rgb: Any,
    *,
    blur_sigma: float = 0.0,
    highpass_sigma: float | None = None,
    contrast: float = 1.0,
    invert: bool = False,
) -> np.ndarray:
    """Heightmap approximated from a photo's brightness (seed 000 §2.7).

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
    y = _brightness(rgb)
    if isinstance(rgb, np.ndarray) and np.shares_memory(y, rgb):
        y = y.copy()  # the steps below work in place; never on the caller's array
    # In place from here on (same arithmetic): one float64 image plus the filter's output.
    if invert:
        np.subtract(1.0, y, out=y)
    if blur > 0.0:
        y = ndimage.gaussian_filter(y, blur, mode="reflect")
    if hp is not None:
        y -= ndimage.gaussian_filter(y, hp, mode="reflect")
    lo, hi = float(y.min()), float(y.max())
    # Relative threshold: a constant image blurred in float64 is not exactly constant.
    if hi - lo <= 1e-9 * max(1.0, abs(hi)):
        return np.zeros(y.shape, dtype=np.float32)
    y -= lo
    y /= hi - lo
    if gamma != 1.0:
        y **= gamma
    np.clip(y, 0.0, 1.0, out=y)
    return y.astype(np.float32)


__all__ = ["height_from_image"]
