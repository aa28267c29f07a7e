"""Engine exports' shared steps: height and weight codes in bands of rows, the same as on
the whole map, and the peak memory of an export with its layers."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from terrascape.export import _common, get_destination
from terrascape.export._common import ExportOptions, uint16_codes, weight_codes
from terrascape.generate import fbm


def test_codes_in_bands_equal_the_whole_map_formulas(monkeypatch):
    rng = np.random.default_rng(7)
    heights = (rng.random((53, 31)) * 900.0 - 100.0).astype(np.float32)
    weights = rng.random((53, 31, 5)).astype(np.float32)
    weights[0, 0] = (0.0, 1.0, 0.5, 0.25, 0.75)  # 127.5 and 191.25: ties go to even
    lo, hi = float(heights.min()) + 20.0, float(heights.max()) - 30.0  # some codes clip
    whole = np.clip(np.rint((heights.astype(np.float64) - lo) * (65535.0 / (hi - lo))),
                    0, 65535).astype(np.uint16)
    layer = np.rint(weights.astype(np.float64) * 255).clip(0, 255).astype(np.uint8)
    monkeypatch.setattr(_common, "_CODE_ROWS", 7)  # 8 bands, the last of 4 rows
    assert np.array_equal(uint16_codes(heights, lo, hi), whole)
    assert (whole == 0).any() and (whole == 65535).any()
    assert np.array_equal(weight_codes(weights), layer)
    assert np.array_equal(weight_codes(weights[..., 2]), layer[..., 2])
    assert np.array_equal(uint16_codes(heights, 5.0, 5.0), np.zeros((53, 31), np.uint16))


@pytest.mark.parametrize(("name", "fit", "limit"), [("unreal", None, 34.0),
                                                    ("unity", "pad", 60.0)])
def test_engine_export_peak_memory(tmp_path, name, fit, limit):
    """numpy reports its arrays to tracemalloc. An export with its texture layers holds the
    heights' codes, the layers' float32 weights and their 8-bit codes, and a band's float64
    temporaries; before the bands it made float64 copies of the whole map and of every
    layer's weights: 62 B a sample (Unreal) and 118 B (Unity) at 1009², now 28 and 52 B
    (Unity pads the map to 1025² and holds each tile's raw bytes)."""
    hm = fbm(1009, seed=4).scaled(300.0)
    options = ExportOptions(name="T", fit=fit)
    get_destination(name).export(hm, tmp_path / "warm", options)  # compiled first
    tracemalloc.start()
    try:
        get_destination(name).export(hm, tmp_path / "out", options)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    per_sample = peak / hm.heights.size
    assert per_sample < limit, f"{per_sample:.1f} B a sample"
