import numpy as np
import pytest

from terrascape.analysis import radial_power_spectrum, spectral_slope


def test_sinusoid_peaks_at_its_frequency():
    n = 256
    x = np.arange(n)
    f0 = 16 / n
    h = np.sin(2 * np.pi * f0 * x)[None, :] * np.ones((n, 1))
    f, p = radial_power_spectrum(h, bins=64)
    assert abs(f[np.argmax(p)] - f0) <= (0.5 - 1 / n) / 64


def test_power_law_surface_slope_is_recovered():
    # synthesise a surface with P(f) ∝ f^-3 and check the measured slope
    n = 256
    rng = np.random.default_rng(1)
    fy = np.fft.fftfreq(n)[:, None]
    fx = np.fft.fftfreq(n)[None, :]
    r = np.hypot(fx, fy)
    r[0, 0] = 1.0
    amplitude = r ** (-1.5)
    phase = np.exp(2j * np.pi * rng.random((n, n)))
    h = np.real(np.fft.ifft2(amplitude * phase))
    f, p = radial_power_spectrum(h)
    assert spectral_slope(f, p, f_min=0.02, f_max=0.3) == pytest.approx(-3.0, abs=0.3)


def test_white_noise_is_flat():
    h = np.random.default_rng(2).standard_normal((128, 128))
    f, p = radial_power_spectrum(h)
    assert abs(spectral_slope(f, p, f_min=0.05, f_max=0.45)) < 0.3
