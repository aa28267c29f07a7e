"""Radially averaged power spectrum of a heightmap.

Used to show *why* the square-root roughness decay of Filipović 2008 §5.3.1 loses the high
frequencies: its spectrum falls off a cliff after the first few octaves while the halving law
keeps a power-law (fractal) slope, ``P(f) ∝ f^-(2H+2)`` for fractional Brownian surfaces
(Saupe, "Algorithms for random fractals", in *The Science of Fractal Images*, 1988).
"""

from __future__ import annotations

import numpy as np

from terrascape._validate import as_height_array, check_int


def radial_power_spectrum(heights, *, bins: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mean power per radial frequency band.

    The mean is removed and a Hann window applied (so the non-periodic edges of a fractal
    terrain do not leak power into every frequency). Frequencies are in cycles per sample,
    from ``1/N`` to the Nyquist limit 0.5.

    Returns
    -------
    frequency, power
        float64 arrays of equal length (bands with no samples are dropped).
    """
    h = as_height_array(heights).astype(np.float64)
    rows, cols = h.shape
    n = min(rows, cols)
    bins = check_int(bins if bins is not None else n // 2, "bins", minimum=2)
    h = h - h.mean()
    window = np.outer(np.hanning(rows), np.hanning(cols))
    power = np.abs(np.fft.fft2(h * window)) ** 2 / (rows * cols)
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.fftfreq(cols)[None, :]
    radius = np.hypot(fx, fy)
    edges = np.linspace(1.0 / n, 0.5, bins + 1)
    index = np.digitize(radius.ravel(), edges) - 1
    valid = (index >= 0) & (index < bins)
    sums = np.bincount(index[valid], weights=power.ravel()[valid], minlength=bins)
    counts = np.bincount(index[valid], minlength=bins)
    keep = counts > 0
    centres = 0.5 * (edges[:-1] + edges[1:])
    return centres[keep], sums[keep] / counts[keep]


def spectral_slope(frequency: np.ndarray, power: np.ndarray, *, f_min: float = 0.0,
                   f_max: float = 0.5) -> float:
    """Least-squares slope of ``log P`` against ``log f`` over ``[f_min, f_max]``."""
    f = np.asarray(frequency, dtype=np.float64)
    p = np.asarray(power, dtype=np.float64)
    sel = (f >= f_min) & (f <= f_max) & (p > 0)
    if sel.sum() < 2:
        return float("nan")
    slope, _ = np.polyfit(np.log(f[sel]), np.log(p[sel]), 1)
    return float(slope)
