"""Local helpers for lighting tests: small random terrains that do not depend on generators."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage


def make_terrain(n: int, seed: int, *, relief: float = 0.15, cols: int | None = None) -> np.ndarray:
    """Smoothed multi-scale noise (fBm-like), heights in [0, relief·n]; float32 (n, cols)."""
    rng = np.random.default_rng(seed)
    shape = (n, cols or n)
    h = np.zeros(shape)
    for sigma in (1, 2, 4, 8, 16):
        h += ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap") * sigma**1.6
    h -= h.min()
    h *= relief * n / h.max()
    return h.astype(np.float32)


@pytest.fixture
def terrain():
    return make_terrain
