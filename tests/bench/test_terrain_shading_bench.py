"""bench terrain_shading: every cut has its row, paired ratios and picture differences."""

from __future__ import annotations

import pytest

from terrascape.bench import available_cases, terrain_shading

pytestmark = pytest.mark.gl


def test_bench_rows_on_a_small_frame(monkeypatch: pytest.MonkeyPatch) -> None:
    assert "terrain_shading" in available_cases()
    monkeypatch.setattr(terrain_shading, "SIZE", (160, 90))
    monkeypatch.setattr(terrain_shading, "QUICK_SIDE", 65)
    monkeypatch.setattr(terrain_shading, "ROAM_TRIANGLES", 4000)
    monkeypatch.setattr(terrain_shading, "QUICK_FRAMES", 1)
    monkeypatch.setattr(terrain_shading, "QUICK_ROUNDS", 1)
    (table,) = terrain_shading.run(quick=True)
    labels = [r[0] for r in table.rows]
    assert labels[0] == "material: before"
    assert "material: + 3 heaviest layers" in labels
    assert "plain: + 3 heaviest layers" not in labels  # a material-only cut
    ratio, mean, peak = (table.columns.index(c) for c in ("× before", "mean diff", "max diff"))
    rows = {r[0]: r for r in table.rows}
    assert rows["material: before"][ratio] == 1.0
    assert rows["material: before"][mean] == 0.0
    for row in table.rows:
        assert row[ratio] > 0
        assert row[mean] < 2.0  # the cuts keep the picture
    # the cuts change pixels (they are real): the default is not bit-identical to before
    assert rows["material: + one mip level per pixel (default)"][peak] > 0
    # the geometry buffer and lookup cuts keep the picture of the cut before them
    base = rows["material: + 8-bit visibility"][mean]
    for label in ("material: + light geometry buffer",
                  "material: + one mip level per pixel (default)"):
        assert abs(rows[label][mean] - base) < 0.05
    assert "plain: + light geometry buffer" not in labels
