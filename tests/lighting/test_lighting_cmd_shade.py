from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.cli.cmd_shade import encode_png_rgba16
from terrascape.heightmap import Heightmap
from terrascape.io import read_heightmap, write_heightmap
from terrascape.lighting import lightmap, pack_normal_height


def _decode_png_rgba16(data: bytes) -> np.ndarray:
    """Minimal independent decoder for the filter-0, 16-bit RGBA PNGs we write."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length : pos + 12 + length])
        assert crc == zlib.crc32(kind + body) & 0xFFFFFFFF
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    cols, rows, depth, ctype = ihdr[:4]
    assert (depth, ctype) == (16, 6)
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(rows, 1 + cols * 8)
    assert (raw[:, 0] == 0).all()
    return raw[:, 1:].copy().view(">u2").reshape(rows, cols, 4).astype(np.uint16)


@pytest.fixture
def hm_file(tmp_path):
    h = np.zeros((33, 33), np.float32)
    h[16, 16] = 10.0
    hm = Heightmap(h)
    path = tmp_path / "spike.npy"
    write_heightmap(hm, path)
    return path


def test_png16_encoder_roundtrip(rng):
    a = rng.integers(0, 65536, size=(5, 7, 4), dtype=np.uint16)
    np.testing.assert_array_equal(_decode_png_rgba16(encode_png_rgba16(a)), a)


def test_normalmap_8_and_16_bit(tmp_path, hm_file):
    out8 = tmp_path / "n8.png"
    assert run_app(["normalmap", str(hm_file), "-o", str(out8), "-q"]) == 0
    img = np.array(Image.open(out8))
    expect = pack_normal_height(read_heightmap(hm_file), bits=8)
    np.testing.assert_array_equal(img, expect)
    assert tuple(img[0, 0]) == (128, 128, 255, 0) and img[16, 16, 3] == 255

    out16 = tmp_path / "n16.png"
    args = ["normalmap", str(hm_file), "-o", str(out16), "--bits", "16", "--height-scale", "2"]
    assert run_app([*args, "-q"]) == 0
    got = _decode_png_rgba16(out16.read_bytes())
    expect16 = pack_normal_height(read_heightmap(hm_file), bits=16, height_scale=2.0)
    np.testing.assert_array_equal(got, expect16)

    # exists → exit 2 and untouched; --force overwrites
    before = out16.read_bytes()
    assert run_app([*args, "-q"]) == 2
    assert out16.read_bytes() == before
    assert run_app([*args, "-q", "--force", "--bits", "8"]) == 0
    assert np.array(Image.open(out16)).dtype == np.uint8


def test_normalmap_rejects_bad_input(tmp_path, hm_file):
    junk = tmp_path / "junk.png"
    junk.write_text("not an image")
    out = tmp_path / "o.png"
    assert run_app(["normalmap", str(junk), "-o", str(out)]) == 2
    assert run_app(["normalmap", str(tmp_path / "missing.npy"), "-o", str(out)]) == 2
    assert run_app(["normalmap", str(hm_file), "-o", str(out), "--bits", "12"]) == 2
    assert run_app(["normalmap", str(hm_file), "-o", str(tmp_path / "o.jpg")]) == 2
    assert not out.exists()
    assert not list(tmp_path.glob(".*part*"))  # no temporary leftovers


def test_heightfromimage(tmp_path):
    _z, x = np.mgrid[0:24, 0:40]
    rgb = np.stack([x * 6, x * 6, x * 6], axis=-1).astype(np.uint8)
    src = tmp_path / "photo.png"
    Image.fromarray(rgb).save(src)
    out = tmp_path / "h.png"
    assert run_app(["heightfromimage", str(src), "-o", str(out), "-q"]) == 0
    hm = read_heightmap(out)
    np.testing.assert_allclose(hm.heights[0], np.linspace(0, 1, 40), atol=1e-4)
    out2 = tmp_path / "h2.png"
    args = ["heightfromimage", str(src), "-o", str(out2), "--contrast", "2", "--invert",
            "--blur", "0.5", "--highpass", "20", "-q"]
    assert run_app(args) == 0
    h2 = read_heightmap(out2).heights
    assert h2[5, 0] > h2[5, -1]  # inverted: the dark left side is high
    junk = tmp_path / "junk.jpg"
    junk.write_bytes(b"\x00" * 100)
    assert run_app(["heightfromimage", str(junk), "-o", str(tmp_path / "x.png")]) == 2
    assert run_app(["heightfromimage", str(src), "-o", str(out)]) == 2  # exists
    assert run_app(["heightfromimage", str(src), "-o", str(tmp_path / "y.png"),
                    "--contrast", "0"]) == 2


def test_shade(tmp_path, hm_file):
    out = tmp_path / "light.png"
    args = ["shade", str(hm_file), "-o", str(out), "--sun-azimuth", "90",
            "--sun-elevation", "20", "--ambient", "0.1", "--lighting", "classic", "-q"]
    assert run_app(args) == 0
    img = np.array(Image.open(out))
    # `shade` defaults to the daylight model; the thesis's formula is --lighting classic.
    expect = lightmap(read_heightmap(hm_file), 90.0, 20.0, ambient=0.1, model="classic")
    np.testing.assert_array_equal(img, np.rint(expect * 255).astype(np.uint8))
    assert (img[16, :15] == round(0.1 * 255)).sum() >= 10  # shadow west of the spike
    out2 = tmp_path / "flat.png"
    assert run_app([*args[:3], str(out2), *args[4:], "--no-shadows", "--method", "reference"]) == 0
    img2 = np.array(Image.open(out2))
    assert img2[16, 5] > img[16, 5]
    for extra in (["--method", "magic"], ["--sun-elevation", "0"], ["--ambient", "2"]):
        assert run_app([*args[:3], str(tmp_path / "bad.png"), *args[4:], *extra]) == 2
    assert not (tmp_path / "bad.png").exists()
    soft = tmp_path / "soft.png"
    assert run_app([*args[:3], str(soft), *args[4:], "--soft"]) == 0


def test_shade_earlier_model_name_still_works_and_names_the_new_one(tmp_path, hm_file, capsys):
    """``--lighting seed`` (the earlier name, hidden from the help) draws the classic model
    and says its new name once."""
    new, old = tmp_path / "classic.png", tmp_path / "seed.png"
    args = ["shade", str(hm_file), "--sun", "90,20", "--ambient", "0.1", "-q"]
    assert run_app([*args, "-o", str(new), "--lighting", "classic"]) == 0
    capsys.readouterr()
    assert run_app([*args, "-o", str(old), "--lighting", "seed"]) == 0
    said = capsys.readouterr()
    text = said.out + said.err
    assert text.count("'classic'") == 1 and "'seed'" in text
    np.testing.assert_array_equal(np.array(Image.open(old)), np.array(Image.open(new)))
    with pytest.warns(FutureWarning, match="classic"):
        earlier = lightmap(read_heightmap(hm_file), 90.0, 20.0, ambient=0.1, model="seed")
    np.testing.assert_array_equal(
        earlier, lightmap(read_heightmap(hm_file), 90.0, 20.0, ambient=0.1, model="classic"))
    capsys.readouterr()
    assert run_app(["shade", "--help"]) == 0
    shown = " ".join(capsys.readouterr().out.split())
    assert "classic" in shown and "seed" not in shown.lower()
