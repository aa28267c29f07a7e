"""Rules tables from a file, fed anything, give a valid rule or one typed error (hypothesis),
and the scatter's bytes do not depend on the number of threads."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from terrascape.errors import InvalidParameterError
from terrascape.objects.rules import ruleset_from_dict

FUZZ = settings(max_examples=80, deadline=None, derandomize=True)
VALUE = st.one_of(st.none(), st.booleans(), st.integers(-5, 500),
                  st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=6),
                  st.lists(st.floats(-100, 100), max_size=4),
                  st.dictionaries(st.sampled_from(["min", "max", "ramp", "x"]),
                                  st.floats(-100, 100), max_size=3))
KEYS = st.sampled_from(["name", "meshes", "density", "spacing", "slope", "height",
                        "height_fraction", "curvature", "masks", "materials", "scale", "oops"])


@FUZZ
@given(table=st.dictionaries(KEYS, VALUE, max_size=7))
def test_any_rule_table_is_valid_or_one_clear_error(table):
    base = {"name": "r", "meshes": ["rock"], "density": 1.0, "spacing": 2.0}
    try:
        rs = ruleset_from_dict({"rules": [{**base, **table}]})
    except InvalidParameterError as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    rule = rs.rules[0]
    assert rule.density >= 0 and rule.spacing > 0 and 0 < rule.scale[0] <= rule.scale[1]
    for band in (rule.slope, rule.height, rule.height_fraction, rule.curvature):
        assert band is None or band.lo <= band.hi


_SCRIPT = """
import sys
from terrascape.generate import generate
from terrascape.objects import scatter
inst = scatter(generate("diamond-square", 65, seed=2, spacing=4.0), seed=5)
sys.stdout.buffer.write(inst.positions.tobytes() + inst.yaw.tobytes() + inst.scale.tobytes()
                        + inst.kind.tobytes())
"""


def test_same_bytes_on_one_or_two_threads():
    src = str(Path(__file__).parents[2] / "src")
    runs = []
    for threads in ("1", "2"):
        env = {**os.environ, "NUMBA_NUM_THREADS": threads, "PYTHONPATH": src}
        done = subprocess.run([sys.executable, "-c", _SCRIPT], capture_output=True, env=env,
                              timeout=300, check=True)
        runs.append(done.stdout)
    assert len(runs[0]) > 100 and runs[0] == runs[1]
    assert np.frombuffer(runs[0][:12], np.float32).shape == (3,)
