"""OpenEXR heightmaps: float and half, one channel, read back with OpenEXR itself."""

from __future__ import annotations

import numpy as np
import pytest

OpenEXR = pytest.importorskip("OpenEXR")

from terrascape import FileFormatError, Heightmap, InvalidParameterError  # noqa: E402
from terrascape.cli import run_app  # noqa: E402
from terrascape.io import FORMATS, read_heightmap, write_heightmap  # noqa: E402
from terrascape.io.exr import half_step, write_exr  # noqa: E402


@pytest.fixture
def terrain(rng) -> Heightmap:
    z, x = np.mgrid[0:33, 0:47]
    h = 400 * np.sin(x / 6.0) * np.cos(z / 7.0) + 20 * rng.random((33, 47)) + 900
    return Heightmap(h.astype(np.float32), (3.0, 4.5), origin=(1000.0, 2000.0),
                     crs="EPSG:32633")


def _channels(path):
    with OpenEXR.File(str(path)) as exr:
        return {k: np.array(v.pixels) for k, v in exr.channels().items()}


def test_exr_is_a_registered_heightmap_format():
    assert FORMATS[".exr"][:2] == (True, True)


def test_float_exr_round_trips_exactly_and_openexr_reads_the_heights(terrain, tmp_path):
    path = write_heightmap(terrain, tmp_path / "h.exr")
    channels = _channels(path)
    assert list(channels) == ["Y"]
    assert channels["Y"].dtype == np.float32 and channels["Y"].shape == (33, 47)
    np.testing.assert_array_equal(channels["Y"], terrain.heights)
    back = read_heightmap(path)
    np.testing.assert_array_equal(back.heights, terrain.heights)
    assert back.spacing == (3.0, 4.5)
    assert (back.origin, back.crs, back.metadata["step"]) == ((1000.0, 2000.0), "EPSG:32633", 0)


def test_half_exr_within_half_an_ulp(terrain, tmp_path):
    path = write_heightmap(terrain, tmp_path / "h16.exr", format="exr16")
    y = _channels(path)["Y"]
    assert y.dtype == np.float16
    step = half_step(terrain.max)
    assert step == 0.5  # heights ≈ 500 … 1320: ulp 1 above 1024, rounding error ≤ ½ ulp
    err = np.abs(y.astype(np.float64) - terrain.heights).max()
    assert 0 < err <= step
    back = read_heightmap(path)
    assert back.metadata["dtype"] == "float16" and back.metadata["step"] == step
    np.testing.assert_array_equal(back.heights, y.astype(np.float32))


def test_foreign_exr_with_rgb_channels_reads_r_and_half_overflow_is_refused(tmp_path):
    r = np.linspace(0, 10, 20, dtype=np.float32).reshape(4, 5)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"R": r, "G": r * 0, "B": r * 0}) as exr:
        exr.write(str(tmp_path / "rgb.exr"))
    hm = read_heightmap(tmp_path / "rgb.exr")
    np.testing.assert_array_equal(hm.heights, r)
    with pytest.raises(InvalidParameterError, match="half-float"):
        write_exr(Heightmap(np.full((3, 3), 70000.0)), tmp_path / "big.exr", half=True)
    assert not (tmp_path / "big.exr").exists()
    (tmp_path / "bad.exr").write_bytes(b"v/1\x01 not really")
    with pytest.raises(FileFormatError, match="cannot read EXR"):
        read_heightmap(tmp_path / "bad.exr")
    assert run_app(["convert", str(tmp_path / "rgb.exr"), str(tmp_path / "o.exr")]) == 0
    np.testing.assert_array_equal(_channels(tmp_path / "o.exr")["Y"], r)
