"""Terragen .ter: hand-built files decoded per the spec, round trips, corrupt files."""

from __future__ import annotations

import struct

import numpy as np
import pytest

from terrascape import FileFormatError, Heightmap
from terrascape.io import read_terragen, terragen_encoding, write_terragen


def _ter(chunks: list[bytes]) -> bytes:
    return b"TERRAGENTERRAIN " + b"".join(chunks)


def test_hand_built_file_decodes_per_spec(tmp_path):
    # 4×3 points, SCAL (10, 20, 5) m, HeightScale 256, BaseHeight 100.
    elev = np.array([[0, 256, 512, -256], [1, 2, 3, 4], [-32768, 32767, 0, 128]], "<i2")
    data = _ter(
        [
            b"SIZE",
            struct.pack("<hxx", 2),
            b"XPTS",
            struct.pack("<Hxx", 4),
            b"YPTS",
            struct.pack("<Hxx", 3),
            b"SCAL",
            struct.pack("<3f", 10.0, 20.0, 5.0),
            b"CRAD",
            struct.pack("<f", 6370.0),
            b"CRVM",
            struct.pack("<I", 0),
            b"ALTW",
            struct.pack("<hh", 256, 100),
            elev.tobytes(),
            b"EOF ",
        ]
    )
    (tmp_path / "t.ter").write_bytes(data)
    hm = read_terragen(tmp_path / "t.ter")
    expected = (100 + elev.astype(np.float64) * 256 / 65536) * 5.0
    # First stored row is the south edge; terrascape row 0 is north.
    np.testing.assert_allclose(hm.heights, expected[::-1], rtol=1e-6)
    assert hm.heights[2, 1] == pytest.approx((100 + 1.0) * 5)  # elevation 256 -> +1 unit
    assert hm.shape == (3, 4) and hm.spacing == (10.0, 20.0)
    assert hm.metadata["height_scale"] == 256 and hm.metadata["base_height"] == 100


def test_square_file_with_defaults_and_odd_padding(tmp_path):
    elev = np.arange(9, dtype="<i2").reshape(3, 3) * 1000
    body = [b"SIZE", struct.pack("<hxx", 2), b"ALTW", struct.pack("<hh", 65, -3), elev.tobytes()]
    (tmp_path / "pad.ter").write_bytes(_ter([*body, b"\0\0", b"EOF "]))
    (tmp_path / "nopad.ter").write_bytes(_ter([*body, b"EOF "]))
    expected = ((-3 + elev.astype(float) * 65 / 65536) * 30.0)[::-1]  # default SCAL: 30 m
    for name in ("pad.ter", "nopad.ter"):
        hm = read_terragen(tmp_path / name)
        np.testing.assert_allclose(hm.heights, expected, rtol=1e-6)
        assert hm.spacing == (30.0, 30.0)


@pytest.mark.parametrize(
    ("lo", "hi", "spacing"),
    [
        (-120.0, 2400.0, (30.0, 30.0)),
        (0.0, 1.0, (1.0, 1.0)),
        (5000.0, 5003.0, (0.5, 2.0)),
        (-1e5, 2e5, (1.0, 1.0)),
        (0.0, 1e-3, (100.0, 100.0)),
    ],
)
def test_round_trip_within_quantisation_step(rng, tmp_path, lo, hi, spacing):
    hm = Heightmap(rng.uniform(lo, hi, (9, 12)).astype(np.float32), spacing)
    write_terragen(hm, tmp_path / "r.ter")
    back = read_terragen(tmp_path / "r.ter")
    step = back.metadata["step"]
    assert step <= 1.25 * (hi - lo) / 65535 + 1e-12  # close to the ideal 16-bit step
    err = np.abs(back.heights.astype(np.float64) - hm.heights).max()
    assert err <= step / 2 + 1e-6 * max(abs(lo), abs(hi))
    assert back.spacing == pytest.approx(spacing)
    _vz, hs, base, elev = terragen_encoding(hm.heights, spacing[0])
    assert 1 <= hs <= 32767 and -32768 <= base <= 32767 and elev.dtype == np.dtype("<i2")


def test_isotropic_scale_for_real_terrain_and_odd_sizes(rng, tmp_path):
    hm = Heightmap(rng.uniform(0, 3000, (5, 7)).astype(np.float32), (30.0, 30.0))
    write_terragen(hm, tmp_path / "o.ter")  # 35 points: needs 2 padding bytes
    data = (tmp_path / "o.ter").read_bytes()
    assert data[:16] == b"TERRAGENTERRAIN " and data.endswith(b"EOF ")
    assert len(data) % 4 == 0
    i = data.index(b"SCAL")
    assert struct.unpack_from("<3f", data, i + 4) == (30.0, 30.0, 30.0)
    np.testing.assert_allclose(read_terragen(tmp_path / "o.ter").heights, hm.heights, atol=0.05)


def test_flat_map(tmp_path):
    for value in (0.0, 812.25):
        hm = Heightmap(np.full((4, 4), value, np.float32))
        write_terragen(hm, tmp_path / f"f{value}.ter")
        back = read_terragen(tmp_path / f"f{value}.ter")
        np.testing.assert_allclose(back.heights, value, atol=1e-3)


def test_bad_header_truncation_and_unknown_chunks(rng, tmp_path):
    (tmp_path / "lev.ter").write_bytes(b"trrn0004" + b"\0" * 40)
    with pytest.raises(FileFormatError, match=r"not a Terragen terrain.*Leveller"):
        read_terragen(tmp_path / "lev.ter")
    (tmp_path / "short.ter").write_bytes(b"TERRA")
    with pytest.raises(FileFormatError, match="not a Terragen"):
        read_terragen(tmp_path / "short.ter")
    write_terragen(Heightmap(rng.random((16, 16)).astype(np.float32)), tmp_path / "ok.ter")
    data = (tmp_path / "ok.ter").read_bytes()
    (tmp_path / "cut.ter").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match="truncated"):
        read_terragen(tmp_path / "cut.ter")
    (tmp_path / "unk.ter").write_bytes(_ter([b"SIZE", struct.pack("<hxx", 2), b"ZZZZ"]))
    with pytest.raises(FileFormatError, match="unknown Terragen chunk"):
        read_terragen(tmp_path / "unk.ter")
    (tmp_path / "noalt.ter").write_bytes(_ter([b"SIZE", struct.pack("<hxx", 2), b"EOF "]))
    with pytest.raises(FileFormatError, match="no ALTW"):
        read_terragen(tmp_path / "noalt.ter")
    (tmp_path / "nosize.ter").write_bytes(_ter([b"ALTW", b"\0" * 8]))
    with pytest.raises(FileFormatError, match="SIZE"):
        read_terragen(tmp_path / "nosize.ter")


def test_low_relief_uses_a_finer_vertical_unit(rng, tmp_path):
    # Relief of 1 m on a 30 m grid: isotropic SCAL would quantise to >= 30/65536 m steps.
    hm = Heightmap(rng.uniform(100.0, 101.0, (6, 6)).astype(np.float32), (30.0, 30.0))
    vz, hs, _base, _ = terragen_encoding(hm.heights, 30.0)
    assert vz < 30.0
    assert hs * vz / 65536 <= 1.25 * 1.0 / 65535
    write_terragen(hm, tmp_path / "low.ter")
    data = (tmp_path / "low.ter").read_bytes()
    sx, sy, sz = struct.unpack_from("<3f", data, data.index(b"SCAL") + 4)
    assert (sx, sy) == (30.0, 30.0) and sz == pytest.approx(vz)
    back = read_terragen(tmp_path / "low.ter")
    assert np.abs(back.heights - hm.heights).max() <= 1.0 / 65535 + 1e-5
