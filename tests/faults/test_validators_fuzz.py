"""The parameter validators and CLI value parsers, fed anything, return a valid value or raise
:class:`InvalidParameterError` (hypothesis, capped examples)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from terrascape._validate import (
    check_finite,
    check_int,
    check_positive,
    check_range,
    check_size_pow2_plus1,
    make_rng,
)
from terrascape.cli.parsing import parse_floats, parse_size
from terrascape.errors import InvalidParameterError
from terrascape.memory import parse_memory

FUZZ = settings(max_examples=60, deadline=None, derandomize=True)
ANYTHING = st.one_of(
    st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=12),
    st.binary(max_size=8), st.lists(st.integers(), max_size=3), st.complex_numbers(),
)


def _valid_or_typed(fn, *args, **kwargs):
    try:
        return fn(*args, **kwargs)
    except InvalidParameterError:
        return None


@FUZZ
@given(value=ANYTHING)
def test_number_checks(value):
    v = _valid_or_typed(check_finite, value, "x")
    assert v is None or math.isfinite(v)
    v = _valid_or_typed(check_positive, value, "x")
    assert v is None or (math.isfinite(v) and v > 0)
    v = _valid_or_typed(check_range, value, "x", -1.0, 2.5)
    assert v is None or -1.0 <= v <= 2.5
    v = _valid_or_typed(check_int, value, "n", minimum=2, maximum=99)
    assert v is None or (type(v) is int and 2 <= v <= 99)
    v = _valid_or_typed(check_size_pow2_plus1, value, algorithm="a")
    assert v is None or (v - 1) & (v - 2) == 0
    _valid_or_typed(make_rng, value)


@FUZZ
@given(text=st.text(max_size=16))
def test_cli_parsers(text):
    wh = _valid_or_typed(parse_size, text)
    assert wh is None or (wh[0] > 0 and wh[1] > 0)
    xyz = _valid_or_typed(parse_floats, text, 3, name="--camera")
    assert xyz is None or (len(xyz) == 3 and all(math.isfinite(v) for v in xyz))
    mem = _valid_or_typed(parse_memory, text)
    assert mem is None or mem >= 1


@pytest.mark.parametrize(("text", "expected"), [
    ("4G", 4 * 1024**3), ("512M", 512 * 1024**2), ("1.5GiB", int(1.5 * 1024**3)),
    ("2e9", 2_000_000_000), ("100", 100), (" 64 kb ", 64 * 1024),
])
def test_parse_memory_units(text, expected):
    assert parse_memory(text) == expected


@pytest.mark.parametrize("text", ["", "G", "-1G", "0", "4X", "50%%", "150%", "nan", "inf"])
def test_parse_memory_refuses(text):
    with pytest.raises(InvalidParameterError, match="--max-memory"):
        parse_memory(text)


# --- the CLI end to end: any option text → exit 0/1/2 and one line, never a traceback ----
OPTION_TEXT = st.one_of(
    st.sampled_from(["33", "17", "0", "-5", "1e9", "nan", "inf", "-inf", "", "3x3", "17x9",
                     "4G", "1", "0.5", "1,2", "1,2,3", "abc", "65537", "2**5+1"]),
    st.text(alphabet="0123456789.-+exX,na ", max_size=8),
)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(size=OPTION_TEXT, roughness=OPTION_TEXT, spacing=OPTION_TEXT, memory=OPTION_TEXT)
def test_generate_options_never_crash(tmp_path_factory, size, roughness, spacing, memory):
    import contextlib
    import io

    from terrascape.cli.app import run_app

    out = tmp_path_factory.mktemp("cli") / "o.npy"
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = run_app(["generate", "diamond-square", "--size", size, "--roughness", roughness,
                        "--spacing", spacing, "--max-memory", memory, "-o", str(out), "-q"])
    assert code in (0, 1, 2), err.getvalue()
    assert "Traceback" not in err.getvalue()
    if code == 0:
        import numpy as np

        assert np.isfinite(np.load(out)).all()
    else:
        assert not out.exists()
        assert err.getvalue().count("error:") == 1
