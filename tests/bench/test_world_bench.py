"""The world benchmark's load-independent speed-up model and its task-stream bookkeeping."""

from __future__ import annotations

import pytest

from terrascape.bench.world import _task_seconds, schedule_speedup


def test_schedule_speedup_of_even_uneven_and_serial_work():
    # Four equal tasks: two workers halve the time.
    assert schedule_speedup({"a": [1.0] * 4}, 0.0) == pytest.approx(2.0)
    # One task per stage cannot be shared: no speed-up at all.
    assert schedule_speedup({"a": [1.0], "b": [2.0]}, 0.0) == pytest.approx(1.0)
    # Three equal tasks: the last runs alone (3 / 2).
    assert schedule_speedup({"a": [1.0] * 3}, 0.0) == pytest.approx(1.5)
    # Serial time outside the tasks stays: (2 + 4) / (2 + 2).
    assert schedule_speedup({"a": [1.0] * 4}, 2.0) == pytest.approx(1.5)
    # In order to the first free worker: 3, then 1 + 1 + 1 on the other → makespan 3.
    assert schedule_speedup({"a": [3.0, 1.0, 1.0, 1.0]}, 0.0) == pytest.approx(2.0)


def test_task_seconds_assigns_tasks_to_their_stage_by_start_time():
    stream = [
        {"startstops": [{"action": "compute", "start": 10.2, "stop": 11.0}]},
        {"startstops": [{"action": "transfer", "start": 9.0, "stop": 9.1},
                        {"action": "compute", "start": 12.5, "stop": 13.0}]},
        {"startstops": [{"action": "compute", "start": 10.0, "stop": 10.1}]},
    ]
    got = _task_seconds(stream, {"height": (10.0, 12.0), "normals": (12.1, 14.0)})
    assert got["height"] == pytest.approx([0.1, 0.8])
    assert got["normals"] == pytest.approx([0.5])
