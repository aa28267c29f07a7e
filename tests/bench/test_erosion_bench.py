"""bench erosion: the table's rows and figures on small sizes, and the real DEM's drainage."""

from __future__ import annotations

import math

import pytest

from terrascape.analysis.drainage import drainage_statistics
from terrascape.bench import available_cases
from terrascape.bench import erosion as bench_erosion


def test_real_dem_drains_like_real_terrain() -> None:
    dem = bench_erosion.real_dem()
    assert dem.shape == (344, 403)
    assert 60.0 < dem.spacing[0] < dem.spacing[1] < 100.0  # 3″ at 36.6° N
    # one DEM for every benchmark, its east–west spacing at the centre latitude (36.59° N)
    from terrascape.bench import peers

    assert peers.real_dem is bench_erosion.real_dem
    assert dem.spacing[0] == pytest.approx(3 / 3600 * 111_320.0 * math.cos(math.radians(
        36.5896)), rel=1e-5)
    assert "_sample_dem" not in available_cases()
    st = drainage_statistics(dem)
    assert 0.40 <= st.beta <= 0.55
    assert st.depression_share < 0.10


def test_bench_table_on_small_sizes(monkeypatch: pytest.MonkeyPatch) -> None:
    assert "erosion" in available_cases()
    monkeypatch.setattr(bench_erosion, "QUICK_SIZES", (129,))
    (table,) = bench_erosion.run(quick=True)
    rows = {(r[0], r[1]): r for r in table.rows}
    raw = rows[("raw fBm", "129²")]
    default = rows[("stream-power", "129²")]
    assert {r[0] for r in table.rows} >= {"raw fBm", "stream-power", "grid", "droplets",
                                           "thermal"}
    depressions = table.columns.index("depressions (%)")
    assert default[depressions] < raw[depressions]
    assert default[depressions] <= 10.0
    assert default[table.columns.index("time (s)")] > 0
    assert any(n.startswith("targets met:") for n in table.notes)
    assert "depressions" in " ".join(table.notes)
    assert bench_erosion.bench_terrain(129).max == pytest.approx(300.0)
