"""Image heightmaps: 8/16-bit gray, RGB luminance, terrascape PNG chunk, previews, corruption."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image, PngImagePlugin

from terrascape import FileFormatError, Heightmap, InvalidParameterError
from terrascape.io import luminance, read_image, write_png16, write_preview


def _hm(rng, shape=(13, 19), lo=-250.0, hi=1800.0, spacing=(2.0, 3.5)) -> Heightmap:
    return Heightmap(rng.uniform(lo, hi, shape).astype(np.float32), spacing)


def test_png16_round_trip_restores_world_units_and_spacing(rng, tmp_path):
    hm = _hm(rng)
    write_png16(hm, tmp_path / "h.png")
    back = read_image(tmp_path / "h.png")
    step = (hm.max - hm.min) / 65535
    assert back.shape == hm.shape
    assert back.spacing == (2.0, 3.5)
    err = np.abs(back.heights.astype(np.float64) - hm.heights)
    assert err.max() <= step / 2 + 1e-4  # half a step, plus float32 rounding at ~1800
    assert back.min == pytest.approx(hm.min, abs=1e-3)
    assert back.max == pytest.approx(hm.max, abs=1e-3)
    assert back.metadata["dtype"] == "uint16"
    assert back.metadata["step"] == pytest.approx(step)
    # The file really is 16-bit grayscale with a JSON tEXt chunk.
    with Image.open(tmp_path / "h.png") as im:
        assert im.mode.startswith("I;16")
        record = json.loads(im.text["terrascape"])
    assert record["offset"] == pytest.approx(hm.min)
    assert np.asarray(Image.open(tmp_path / "h.png")).max() == 65535


def test_png16_vertical_scale_multiplies_restored_units(rng, tmp_path):
    hm = _hm(rng)
    write_png16(hm, tmp_path / "h.png")
    back = read_image(tmp_path / "h.png", vertical_scale=2.0, spacing=7.0)
    np.testing.assert_allclose(back.heights, 2 * hm.heights, atol=2 * (hm.max - hm.min) / 65535)
    assert back.spacing == (7.0, 7.0)


def test_plain_8bit_gray_scales_by_255_times_vertical_scale(tmp_path):
    codes = np.array([[0, 51, 102], [153, 204, 255]], dtype=np.uint8)
    Image.fromarray(codes).save(tmp_path / "g.png")
    Image.fromarray(codes).save(tmp_path / "g.bmp")
    for name in ("g.png", "g.bmp"):
        hm = read_image(tmp_path / name, vertical_scale=100.0)
        np.testing.assert_allclose(hm.heights, codes / 255 * 100.0, rtol=1e-6)
        assert hm.spacing == (1.0, 1.0)
        assert hm.metadata["dtype"] == "uint8"
        assert hm.metadata["units_restored"] is False


def test_plain_16bit_gray_scales_by_65535(tmp_path):
    codes = np.array([[0, 1000, 65535], [30000, 7, 12345]], dtype=np.uint16)
    Image.fromarray(codes).save(tmp_path / "g16.png")  # no terrascape chunk
    hm = read_image(tmp_path / "g16.png")
    np.testing.assert_allclose(hm.heights, codes / 65535, rtol=1e-6)


def test_rgb_and_rgba_use_rec601_luma(tmp_path):
    rgb = np.array(
        [[[255, 0, 0], [0, 255, 0], [0, 0, 255]], [[255, 255, 255], [10, 20, 30], [0, 0, 0]]],
        dtype=np.uint8,
    )
    Image.fromarray(rgb).save(tmp_path / "c.png")
    hm = read_image(tmp_path / "c.png")
    expected = (0.299 * rgb[..., 0] + 0.587 * rgb[..., 1] + 0.114 * rgb[..., 2]) / 255
    np.testing.assert_allclose(hm.heights, expected, rtol=1e-6)
    assert hm.heights[0, 0] == pytest.approx(0.299, abs=1e-6)
    assert hm.heights[0, 1] == pytest.approx(0.587, abs=1e-6)
    assert hm.heights[1, 0] == pytest.approx(1.0, abs=1e-6)
    # Alpha does not change the height.
    rgba = np.concatenate([rgb, np.full((*rgb.shape[:2], 1), 17, np.uint8)], axis=-1)
    Image.fromarray(rgba).save(tmp_path / "c4.png")
    np.testing.assert_allclose(read_image(tmp_path / "c4.png").heights, hm.heights)
    assert luminance(np.array([10.0, 20.0, 30.0])) == pytest.approx(2.99 + 11.74 + 3.42)


def test_palette_image_reads_as_luma(tmp_path):
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[:2] = (200, 100, 50)
    Image.fromarray(rgb).convert("P", palette=Image.Palette.ADAPTIVE).save(tmp_path / "p.png")
    hm = read_image(tmp_path / "p.png")
    assert hm.heights[0, 0] == pytest.approx((0.299 * 200 + 0.587 * 100 + 0.114 * 50) / 255, 1e-3)
    assert hm.heights[3, 3] == 0.0


def test_jpeg_gray_reads_close_to_source(tmp_path):
    ramp = np.tile(np.linspace(0, 255, 32).astype(np.uint8), (32, 1))
    Image.fromarray(ramp).save(tmp_path / "r.jpg", quality=95)
    hm = read_image(tmp_path / "r.jpg", vertical_scale=255.0)
    assert np.abs(hm.heights - ramp).max() < 6  # lossy, but a ramp survives
    assert hm.metadata["format"] == "jpeg"


def test_preview_png_and_bmp(rng, tmp_path):
    hm = _hm(rng)
    write_preview(hm, tmp_path / "p.png")
    write_preview(hm, tmp_path / "p.bmp")
    with Image.open(tmp_path / "p.bmp") as im:
        assert im.mode == "L"
        codes = np.asarray(im)
    assert codes.min() == 0 and codes.max() == 255
    expected = np.rint((hm.heights.astype(np.float64) - hm.min) / (hm.max - hm.min) * 255)
    np.testing.assert_array_equal(codes, expected)
    # The PNG preview carries an 8-bit chunk: world units within half an 8-bit step.
    back = read_image(tmp_path / "p.png")
    assert np.abs(back.heights - hm.heights).max() <= (hm.max - hm.min) / 255 / 2 + 1e-3
    assert back.spacing == hm.spacing
    with pytest.raises(FileFormatError, match=r"\.png or \.bmp"):
        write_preview(hm, tmp_path / "p.gif")


def test_flat_map_round_trips(tmp_path):
    hm = Heightmap(np.full((5, 6), 42.5, np.float32))
    write_png16(hm, tmp_path / "f.png")
    np.testing.assert_array_equal(read_image(tmp_path / "f.png").heights, 42.5)


def test_truncated_png_is_a_file_format_error(rng, tmp_path):
    write_png16(_hm(rng, shape=(64, 64)), tmp_path / "h.png")
    data = (tmp_path / "h.png").read_bytes()
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match="cannot read image"):
        read_image(tmp_path / "cut.png")
    (tmp_path / "junk.png").write_bytes(b"not a png at all")
    with pytest.raises(FileFormatError):
        read_image(tmp_path / "junk.png")


def test_corrupt_terrascape_chunk_is_an_error(tmp_path):
    info = PngImagePlugin.PngInfo()
    info.add_text("terrascape", "{not json")
    Image.fromarray(np.zeros((3, 3), np.uint16)).save(tmp_path / "bad.png", pnginfo=info)
    with pytest.raises(FileFormatError, match="corrupt terrascape metadata"):
        read_image(tmp_path / "bad.png")


def test_bad_parameters(rng, tmp_path):
    write_png16(_hm(rng), tmp_path / "h.png")
    with pytest.raises(InvalidParameterError, match="vertical_scale"):
        read_image(tmp_path / "h.png", vertical_scale=-1)
    with pytest.raises(InvalidParameterError, match="spacing"):
        read_image(tmp_path / "h.png", spacing=(1, 2, 3))
    with pytest.raises(FileFormatError, match="not found"):
        read_image(tmp_path / "missing.png")
    with pytest.raises(InvalidParameterError, match="Heightmap"):
        write_png16(np.zeros((3, 3)), tmp_path / "x.png")


def _zlib_level_class(path) -> int:
    """FLEVEL of the PNG's zlib stream (0 fastest … 3 best): zlib writes 1 for levels 2–5 and
    2 for its default, 6."""
    data = path.read_bytes()
    at = 8
    while at < len(data):
        length = int.from_bytes(data[at:at + 4], "big")
        if data[at + 4:at + 8] == b"IDAT":
            return data[at + 9] >> 6  # the stream's second byte (FLG)
        at += 12 + length
    raise AssertionError("no IDAT chunk")


def test_16bit_height_pngs_are_compressed_at_the_faster_level(rng, tmp_path):
    """16-bit heights go out at zlib level 4 (about the bytes of Pillow's default in up to
    a third of the time), read back to the same codes; 8-bit images keep the default."""
    from terrascape.export._common import write_png
    from terrascape.io.image import PNG16_COMPRESS_LEVEL

    assert PNG16_COMPRESS_LEVEL == 4
    hm = _hm(rng, shape=(300, 200))
    write_png16(hm, tmp_path / "h.png")
    assert _zlib_level_class(tmp_path / "h.png") == 1
    codes = rng.integers(0, 65536, (64, 48), dtype=np.uint16)
    write_png(tmp_path / "e.png", codes, force=False)
    assert _zlib_level_class(tmp_path / "e.png") == 1
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "e.png")), codes)
    write_png(tmp_path / "w.png", (codes >> 8).astype(np.uint8), force=False)
    assert _zlib_level_class(tmp_path / "w.png") == 2
