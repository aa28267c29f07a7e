"""Fit the polynomial sRGB transfer curves used by the shaders (common/atmosphere.glsl).

    python scripts/fit_srgb_curves.py

A software rasteriser evaluates ``pow`` as a log2 and an exp2 series per channel, so the
shaders use polynomials instead, fitted here by minimax (Nelder–Mead from the least-squares
fit) to the standard curves of IEC 61966-2-1:

* encode: ``1.055·c^(1/2.4) − 0.055`` on [0.0031308, 1] as a quartic in ``t = c^(1/4)``
  (two square roots), error in display units;
* decode: ``((c + 0.055)/1.055)^2.4`` on [0.04045, 1] as a quintic in ``c``, error measured
  after encoding back with the exact curve (what a displayed albedo can be off by).

Prints the coefficients (constant first) and each fit's largest error in 1/255 steps.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from terrascape.lighting.daylight import linear_to_srgb, srgb_to_linear


def _minimax(basis: np.ndarray, error) -> np.ndarray:
    w = np.linalg.lstsq(basis, error.target, rcond=None)[0]
    for _ in range(6):  # restarts: Nelder–Mead stalls on the max-norm's corners
        w = minimize(error, w, method="Nelder-Mead",
                     options={"maxiter": 60000, "xatol": 1e-13, "fatol": 1e-13}).x
    return w


def fit_encode() -> tuple[np.ndarray, float]:
    c = np.linspace(0.0031308, 1.0, 100001)
    t = np.sqrt(np.sqrt(c))
    basis = np.stack([t**k for k in range(5)], 1)
    exact = linear_to_srgb(c)

    def error(w):
        return np.abs(basis @ w - exact).max()

    error.target = exact
    w = _minimax(basis, error)
    return w, 255.0 * error(w)


def fit_decode() -> tuple[np.ndarray, float]:
    c = np.linspace(0.04045, 1.0, 100001)
    basis = np.stack([c**k for k in range(6)], 1)

    def error(w):
        return np.abs(linear_to_srgb(np.clip(basis @ w, 0.0, 1.0)) - c).max()

    error.target = srgb_to_linear(c)
    w = _minimax(basis, error)
    return w, 255.0 * error(w)


def main() -> None:
    for name, fit in (("encode (powers of c^(1/4))", fit_encode),
                      ("decode (powers of c)", fit_decode)):
        w, err = fit()
        print(f"{name}: largest error {err:.3f}/255")
        print("  " + ", ".join(f"{x:.10f}" for x in w))


if __name__ == "__main__":
    main()
