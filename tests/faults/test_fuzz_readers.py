"""Every heightmap reader, fed random or corrupted bytes, returns a valid heightmap or raises
a typed :class:`TerrascapeError` — never another exception (hypothesis, capped examples)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from terrascape import Heightmap
from terrascape.errors import TerrascapeError
from terrascape.io import read_heightmap, write_heightmap

FUZZ = settings(max_examples=25, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture])
EXTENSIONS = (".png", ".bmp", ".jpg", ".r16", ".raw", ".r32", ".tif", ".npy", ".ter")
WRITABLE = (".png", ".r16", ".r32", ".tif", ".npy", ".ter")


def _read_or_typed_error(path) -> Heightmap | None:
    try:
        hm = read_heightmap(path)
    except TerrascapeError:
        return None
    except Exception as exc:  # pragma: no cover - the failure this test exists to catch
        pytest.fail(f"{path.name}: untyped {type(exc).__name__}: {exc}")
    # A heightmap that is returned is a valid one.
    assert isinstance(hm, Heightmap)
    assert hm.heights.dtype == np.float32 and hm.heights.ndim == 2
    assert np.isfinite(hm.heights).all()
    return hm


@pytest.fixture(scope="module")
def valid_files(tmp_path_factory):
    """One small valid file per writable format (the seeds of the corruption tests)."""
    folder = tmp_path_factory.mktemp("valid")
    rng = np.random.default_rng(3)
    hm = Heightmap(rng.random((9, 12)).astype(np.float32) * 100, (2.0, 3.0))
    files = {}
    for ext in WRITABLE:
        path = folder / f"seed{ext}"
        write_heightmap(hm, path)
        files[ext] = path.read_bytes()
    files[".r16.json"] = (folder / "seed.r16.json").read_bytes()
    return files


@FUZZ
@given(ext=st.sampled_from(EXTENSIONS), data=st.binary(min_size=0, max_size=600))
def test_random_bytes(tmp_path, ext, data):
    path = tmp_path / f"fuzz{ext}"
    path.write_bytes(data)
    _read_or_typed_error(path)


@FUZZ
@given(ext=st.sampled_from(WRITABLE), cut=st.floats(0.0, 1.0),
       flips=st.lists(st.tuples(st.floats(0.0, 1.0), st.integers(0, 255)), max_size=6))
def test_truncated_and_corrupted_valid_files(tmp_path, valid_files, ext, cut, flips):
    data = bytearray(valid_files[ext])
    for where, value in flips:
        data[min(int(where * len(data)), len(data) - 1)] = value
    data = data[: max(1, int(cut * len(data)))] if cut < 1.0 else data
    path = tmp_path / f"bad{ext}"
    path.write_bytes(bytes(data))
    _read_or_typed_error(path)


@FUZZ
@given(record=st.dictionaries(
    st.sampled_from(["format", "version", "dtype", "cols", "rows", "offset", "scale",
                     "spacing", "sha256"]),
    st.one_of(st.none(), st.booleans(), st.integers(-5, 70000), st.floats(allow_nan=False),
              st.text(max_size=70), st.lists(st.floats(-3, 3), max_size=3)),
))
def test_random_sidecars(tmp_path, valid_files, record):
    (tmp_path / "s.r16").write_bytes(valid_files[".r16"])
    base = json.loads(valid_files[".r16.json"])
    (tmp_path / "s.r16.json").write_text(json.dumps({**base, **record}))
    _read_or_typed_error(tmp_path / "s.r16")


def test_mixed_pair_is_refused_not_misread(tmp_path):
    """A RAW file with another run's sidecar (same size) is detected by the hash."""
    a = Heightmap(np.linspace(0, 100, 64, dtype=np.float32).reshape(8, 8))
    b = Heightmap(np.linspace(0, 900, 64, dtype=np.float32).reshape(8, 8)[::-1].copy())
    write_heightmap(a, tmp_path / "a.r16")
    write_heightmap(b, tmp_path / "b.r16")
    (tmp_path / "a.r16.json").write_bytes((tmp_path / "b.r16.json").read_bytes())
    with pytest.raises(TerrascapeError, match="does not match its sidecar"):
        read_heightmap(tmp_path / "a.r16")
    # The untouched pair reads back within half a quantisation step.
    back = read_heightmap(tmp_path / "b.r16")
    assert np.abs(back.heights - b.heights).max() <= 900 / 65535
