"""``terrascape export unity|unreal|godot|blender``: files read back on their bytes and values,
explicit size fitting, and the import notes' numbers."""

from __future__ import annotations

import re

import numpy as np
import pytest
import tifffile
from PIL import Image
from scipy import ndimage

from terrascape import Heightmap, HeightmapSizeError
from terrascape.cli import run_app
from terrascape.export import ExportOptions, destinations, get_destination


@pytest.fixture(scope="module")
def terrain() -> Heightmap:
    rng = np.random.default_rng(5)
    h = ndimage.gaussian_filter(rng.standard_normal((129, 129)), 5) * 4000 + 800
    return Heightmap(h.astype(np.float32), (10.0, 10.0))


def _note(path) -> str:
    return path.read_text(encoding="utf-8")


def test_registry_lists_every_destination():
    assert {"unity", "unreal", "godot", "blender"} <= set(destinations())


def test_unity_raw_is_16bit_little_endian_south_first(terrain, tmp_path):
    files = get_destination("unity").export(terrain, tmp_path, ExportOptions(name="T"))
    raw = np.fromfile(tmp_path / "T.raw", dtype="<u2").reshape(129, 129)
    lo, hi = terrain.min, terrain.max
    back = lo + raw.astype(np.float64) * (hi - lo) / 65535
    np.testing.assert_allclose(back[::-1], terrain.heights, atol=(hi - lo) / 65535 / 2 + 1e-3)
    assert raw[::-1].argmax() == terrain.heights.argmax()  # rows flipped: south first
    note = _note(tmp_path / "T_import.txt")
    assert "Resolution: 129" in note and "Flip Vertically: off" in note
    height = float(re.search(r"height ([\d.]+)", note).group(1))
    assert height == pytest.approx(hi - lo, rel=1e-5)
    # alphamaps: RGBA, 128², weights of layers 0–3 and 4 sum to 255 (±rounding)
    a0 = np.asarray(Image.open(tmp_path / "T_splat0.png"))
    a1 = np.asarray(Image.open(tmp_path / "T_splat1.png"))
    assert a0.shape == (128, 128, 4) and a1.shape == (128, 128, 4)
    total = a0.astype(int).sum(axis=2) + a1[..., 0]
    assert np.all(np.abs(total - 255) <= 3)
    assert tmp_path / "T_import.txt" in files
    # --flip: image order
    get_destination("unity").export(terrain, tmp_path / "f",
                                    ExportOptions(name="T", flip=True, layers=False))
    flipped = np.fromfile(tmp_path / "f" / "T.raw", dtype="<u2").reshape(129, 129)
    np.testing.assert_array_equal(flipped, raw[::-1])


def test_unity_tiles_share_edges_and_are_named_x_z(terrain, tmp_path):
    get_destination("unity").export(terrain, tmp_path,
                                    ExportOptions(name="T", tiles=2, layers=False))
    full = np.fromfile(tmp_path / "T.raw", dtype="<u2") if (tmp_path / "T.raw").exists() \
        else None
    assert full is None
    tiles = {(x, z): np.fromfile(tmp_path / f"T_{x}_{z}.raw", "<u2").reshape(65, 65)
             for x in (0, 1) for z in (0, 1)}
    np.testing.assert_array_equal(tiles[0, 0][:, -1], tiles[1, 0][:, 0])  # shared column
    np.testing.assert_array_equal(tiles[0, 0][-1], tiles[0, 1][0])  # shared row
    codes_south_first = np.fromfile(tmp_path / "T_0_0.raw", "<u2").reshape(65, 65)
    lo, hi = terrain.min, terrain.max
    south_west = terrain.heights[-65:, :65][::-1]
    np.testing.assert_allclose(lo + codes_south_first * (hi - lo) / 65535, south_west,
                               atol=(hi - lo) / 65535)


def test_wrong_size_is_an_error_listing_sizes_unless_fit(tmp_path):
    hm = Heightmap(np.random.default_rng(1).random((100, 140)).astype(np.float32) * 50)
    with pytest.raises(HeightmapSizeError, match=r"33, 65, 129.*--fit"):
        get_destination("unity").export(hm, tmp_path, ExportOptions())
    assert run_app(["export", "unreal", "missing.npy", "-o", str(tmp_path)]) == 2
    np.save(tmp_path / "odd.npy", hm.heights)
    assert run_app(["export", "unreal", str(tmp_path / "odd.npy"), "-o", str(tmp_path)]) == 2
    assert not list(tmp_path.glob("odd*.png"))
    for fit, side in (("pad", 257), ("crop", 65), ("resample", 129)):
        get_destination("unity").export(hm, tmp_path / fit,
                                        ExportOptions(name="T", fit=fit, layers=False))
        raw = np.fromfile(tmp_path / fit / "T.raw", "<u2")
        assert raw.size == side * side
    # pad keeps every original sample (edges repeated): compare in image order
    padded = np.fromfile(tmp_path / "pad" / "T.raw", "<u2").reshape(257, 257)[::-1]
    lo, hi = hm.min, hm.max
    np.testing.assert_allclose(lo + padded[:100, :140] * (hi - lo) / 65535, hm.heights,
                               atol=(hi - lo) / 65535)


def test_a_failed_export_leaves_no_folder_it_made(tmp_path):
    """An export that stops on bad input takes away the output folder it made (with its
    empty sub-folders), and leaves a folder that was already there and its files alone."""
    hm = Heightmap(np.random.default_rng(2).random((65, 65)).astype(np.float32) * 40)
    np.save(tmp_path / "small.npy", hm.heights)
    src = str(tmp_path / "small.npy")
    made = tmp_path / "new" / "deeper"
    assert run_app(["export", "unreal", src, "-o", str(made)]) == 2  # 65² needs --fit
    assert not (tmp_path / "new").exists()
    assert run_app(["export", "cesium", src, "-o", str(tmp_path / "tiles"),
                    "--lonlat", "200,100"]) == 2
    assert not (tmp_path / "tiles").exists()
    kept = tmp_path / "kept"
    kept.mkdir()
    (kept / "mine.txt").write_text("x")
    assert run_app(["export", "unreal", src, "-o", str(kept)]) == 2
    assert sorted(p.name for p in kept.iterdir()) == ["mine.txt"]
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run_app(["export", "unreal", src, "-o", str(empty)]) == 2
    assert empty.is_dir()  # it was there before
    assert run_app(["export", "unity", src, "-o", str(tmp_path / "ok")]) == 0
    assert (tmp_path / "ok" / "small_import.txt").is_file()


def test_unreal_png_codes_and_z_scale(terrain, tmp_path):
    hm = Heightmap(terrain.heights[:127, :127], (2.0, 2.0))
    assert run_app(["export", "unreal", "--help"]) == 0
    get_destination("unreal").export(hm, tmp_path, ExportOptions(name="L"))
    img = Image.open(tmp_path / "L.png")
    codes = np.asarray(img).astype(np.float64)
    assert img.mode.startswith("I") and codes.shape == (127, 127) and codes.max() == 65535
    note = _note(tmp_path / "L_import.txt")
    z = float(re.search(r"Scale: X [\d.]+  Y [\d.]+  Z ([\d.]+)", note).group(1))
    loc = float(re.search(r"Location: X 0  Y 0  Z ([-\d.]+)", note).group(1))
    # Unreal's rule: metres = (code − 32768) / 128 × Z / 100, plus the actor's Z (cm → m)
    metres = (codes - 32768) / 128.0 * z / 100.0 + loc / 100.0
    np.testing.assert_allclose(metres, hm.heights, atol=0.02 + (hm.max - hm.min) / 65535)
    weights = [np.asarray(Image.open(p)) for p in sorted(tmp_path.glob("L_layer_*.png"))]
    assert len(weights) == 5 and all(w.dtype == np.uint8 and w.shape == (127, 127)
                                     for w in weights)
    assert np.all(np.abs(np.sum(weights, axis=0, dtype=int) - 255) <= 3)
    get_destination("unreal").export(hm, tmp_path / "r", ExportOptions(name="L", format="r16",
                                                                        layers=False))
    r16 = np.fromfile(tmp_path / "r" / "L.r16", "<u2").reshape(127, 127)
    np.testing.assert_array_equal(r16, codes.astype(np.uint16))


def test_unreal_tiles_x_y_names(terrain, tmp_path):
    hm = Heightmap(np.asarray(ndimage.zoom(terrain.heights, 253 / 129, order=1))[:253, :253])
    get_destination("unreal").export(hm, tmp_path, ExportOptions(name="L", tiles=2,
                                                                 layers=False))
    names = sorted(p.name for p in tmp_path.glob("L_x*_y*.png"))
    assert names == ["L_x0_y0.png", "L_x0_y1.png", "L_x1_y0.png", "L_x1_y1.png"]
    a = np.asarray(Image.open(tmp_path / "L_x0_y0.png"))
    b = np.asarray(Image.open(tmp_path / "L_x1_y0.png"))
    assert a.shape == (127, 127)
    np.testing.assert_array_equal(a[:, -1], b[:, 0])


@pytest.mark.parametrize("fmt", ["exr", "exr16"])
def test_godot_exr_holds_real_heights(terrain, tmp_path, fmt):
    OpenEXR = pytest.importorskip("OpenEXR")
    get_destination("godot").export(terrain, tmp_path, ExportOptions(name="G", format=fmt))
    with OpenEXR.File(str(tmp_path / "G.exr")) as exr:
        (channel,) = exr.channels().values()
        y = np.array(channel.pixels)
    assert y.dtype == (np.float32 if fmt == "exr" else np.float16)
    atol = 0 if fmt == "exr" else 2.0  # heights up to ~2600: half ulp 2
    np.testing.assert_allclose(y.astype(np.float64), terrain.heights, atol=atol)
    assert "HTerrain" in _note(tmp_path / "G_import.txt")
    hm = Heightmap(terrain.heights[:100, :120])
    with pytest.raises(HeightmapSizeError):
        get_destination("godot").export(hm, tmp_path / "x", ExportOptions(name="G"))
    files = get_destination("godot").export(hm, tmp_path / "t3",
                                            ExportOptions(name="G", plugin="terrain3d",
                                                          format="r16"))
    codes = np.fromfile(files[0], "<u2").reshape(100, 120)
    note = _note(files[1])
    lo, hi = (float(v) for v in re.search(r"r16_range: \(([-\d.]+), ([-\d.]+)\)", note).groups())
    np.testing.assert_allclose(lo + codes * (hi - lo) / 65535, hm.heights,
                               atol=(hi - lo) / 65535 + 1e-3)


def test_blender_tiff_and_glb(terrain, tmp_path, gltf_validator):
    np.save(tmp_path / "b.npy", terrain.heights)
    assert run_app(["export", "blender", str(tmp_path / "b.npy"), "-o", str(tmp_path / "o"),
                    "--spacing", "10", "-q"]) == 0
    data = tifffile.imread(tmp_path / "o" / "b.tif")
    assert data.dtype == np.float32
    np.testing.assert_array_equal(data, terrain.heights)
    note = _note(tmp_path / "o" / "b_import.txt")
    assert "Midlevel 0" in note and "scale X 1280" in note
    assert run_app(["export", "blender", str(tmp_path / "b.npy"), "-o", str(tmp_path / "g"),
                    "--format", "glb", "-q"]) == 0
    assert gltf_validator(tmp_path / "g" / "b.glb")["numErrors"] == 0
    trimesh = pytest.importorskip("trimesh")
    scene = trimesh.load(tmp_path / "g" / "b.glb", process=False)
    assert scene.bounds[1][1] == pytest.approx(terrain.max, rel=1e-6)


def test_unreal_png_tiles_of_a_utm_dem_are_placed_by_rasterio(terrain, tmp_path):
    """World files (.pgw) and the CRS (.aux.xml) put every PNG tile where it belongs."""
    rasterio = pytest.importorskip("rasterio")
    from rasterio.crs import CRS
    from rasterio.transform import Affine

    h = np.asarray(ndimage.zoom(terrain.heights, 253 / 129, order=1))[:253, :253]
    hm = Heightmap(h.astype(np.float32), (30.0, 30.0), origin=(500000.0, 5000000.0),
                   crs="EPSG:32633")
    get_destination("unreal").export(hm, tmp_path, ExportOptions(name="L", tiles=2,
                                                                 layers=False))
    for i in range(2):
        for j in range(2):
            path = tmp_path / f"L_x{j}_y{i}.png"
            assert path.with_suffix(".pgw").exists()
            with rasterio.open(path) as ds:
                assert ds.crs == CRS.from_epsg(32633)
                # tile (i, j) starts at sample [126·i, 126·j]; the transform is of corners
                assert ds.transform.almost_equals(Affine(
                    30.0, 0.0, 500000.0 + 126 * 30.0 * j, 0.0, -30.0, 5000000.0 - 126 * 30.0 * i))
                np.testing.assert_array_equal(ds.read(1), np.asarray(Image.open(path)))
    # a map without a CRS gets no world file
    get_destination("unreal").export(Heightmap(h.astype(np.float32)), tmp_path / "plain",
                                     ExportOptions(name="L", layers=False))
    assert not list((tmp_path / "plain").glob("*.pgw"))
