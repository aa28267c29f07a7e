"""bench relief: its timing statistics, and the quick run's tables and figures."""

import numpy as np
import pytest

from terrascape.bench import relief as bench_relief


def test_round_times_ratios_pair_rounds():
    t = bench_relief.RoundTimes(["a", "b", "c"])
    # Host speed drifts 2× between rounds; within a round b costs 1.1× a and c 0.4× a more.
    for speed in (1.0, 2.0, 1.5, 1.0, 2.0):
        t.cpu["a"].append(10.0 * speed)
        t.cpu["b"].append(11.0 * speed)
        t.cpu["c"].append(14.0 * speed)
        for k in "abc":
            t.wall[k].append(t.cpu[k][-1] / 2)
    assert t.ratio("b", "a") == pytest.approx(1.1)
    assert t.extra("c", "a", "b") == pytest.approx(4.0 / 11.0)
    assert (t.best_cpu("b"), t.best_wall("b")) == (11.0, 5.5)
    # One round slowed for b alone moves the median by nothing.
    t.cpu["b"][2] *= 3
    assert t.ratio("b", "a") == pytest.approx(1.1)


def test_time_interleaved_alternates_order_and_prepares():
    calls = []
    jobs = {k: (lambda k=k: calls.append(k)) for k in "xyz"}
    prep = {k: (lambda k=k: calls.append(k.upper())) for k in "xyz"}
    times = bench_relief._time_interleaved(jobs, rounds=2, prepare=prep)
    # A warm-up call each, then round 0 forward and round 1 backward, each timed call
    # after its untimed preparation.
    assert calls == list("xyz") + list("XxYyZz") + list("ZzYyXx")
    assert all(len(times.cpu[k]) == 2 and len(times.wall[k]) == 2 for k in "xyz")


@pytest.mark.gl
def test_quick_run_measures_every_technique(gl_ctx):
    tables = bench_relief.quality_tables(gl_ctx, tex=64, fb=96, angles=(60,), quick=True,
                                         rounds=2)
    quality, shadow = tables
    labels = [row[2] for row in quality.rows]
    for label, _, _ in bench_relief.TECHNIQUES:
        assert labels.count(label) == 2  # city and natural
    rows = {(r[0], r[2]): r for r in quality.rows}
    base = rows[("city", "relief 16+8")]
    exact = rows[("city", "min/max exact")]
    parallax = rows[("city", "parallax")]
    assert base[-1] == pytest.approx(1.0)  # the time baseline
    # On the city at 60° exact beats relief 16+8 (mean error, % > 1 texel, % skipped),
    # which beats one-step parallax.
    assert exact[3] < 0.01 < base[3] < parallax[3]
    assert exact[5] < 0.1 < base[5] < parallax[5]
    assert exact[6] < 0.1 < base[6]
    assert parallax[7] == pytest.approx(1.0)  # one fetch per pixel
    assert all(np.isfinite(r[10]) and r[10] > 0 for r in quality.rows)
    # Self-shadowing: relief default and min/max on both fields; min/max agrees exactly.
    assert len(shadow.rows) == 4
    for r in shadow.rows:
        assert 0.0 <= r[3] <= (1.0 if r[2] == "min/max exact" else 20.0)


def test_precision_table_worst_over_seeds(gl_ctx):
    table = bench_relief.precision_table(gl_ctx, tex=32, fb=48, angles=(70,), seeds=(0, 1),
                                         bits=(8, 32))
    families = {row[1] for row in table.rows}
    assert len(families) == 3
    assert {row[0] for row in table.rows} == {"8-bit", "float"}
    exact = [row for row in table.rows if row[3] == "min/max exact"]
    assert len(exact) == 6
    assert all(row[4] <= 0.05 for row in exact)  # exact at every precision
    fences_linear = [row for row in table.rows
                     if row[1].startswith("fences") and row[3] == "relief 16+8"]
    assert max(row[6] for row in fences_linear) > 5.0  # it steps through the fences


def test_cone_map_table_times_both_fields():
    table = bench_relief.cone_map_table(sizes=(32, 64))
    assert [(r[0], r[1]) for r in table.rows] == [("city", "32²"), ("natural", "32²"),
                                                  ("city", "64²"), ("natural", "64²")]
    for _, texels, seconds, per_texel, median in table.rows:
        side = int(texels.rstrip("²"))
        assert 0.0 < seconds < 5.0
        assert per_texel == pytest.approx(seconds / side**2 * 1e9)
        assert 0.0 < median <= 1.0  # cones in UV per unit depth, capped at 1
