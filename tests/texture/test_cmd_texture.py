"""`terrascape texture …` commands, run in-process: outputs, exit codes, all-or-nothing."""

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.cli.cmd_texture import layer_colour
from terrascape.heightmap import Heightmap
from terrascape.texture import (
    builtin_material,
    default_regions,
    material_ids_from_rules,
    pack_splat_maps,
    region_texture,
    splat_weights,
)


@pytest.fixture
def hm_file(tmp_path):
    y, x = np.mgrid[0:33, 0:41] / 32.0
    h = (np.sin(4 * x) * np.cos(3 * y) * 15 + 15 + 20 * x).astype(np.float32)
    path = tmp_path / "hm.npy"
    np.save(path, h)
    return path, Heightmap(h)


def _png(path):
    with Image.open(path) as im:
        return np.asarray(im)


def test_regions_command_writes_the_library_result(tmp_path, hm_file):
    path, hm = hm_file
    out = tmp_path / "tex.png"
    argv = ["texture", "regions", str(path), "-o", str(out), "--scale", "2", "--jitter", "0.2",
            "--seed", "3", "--texture-size", "64", "-q"]
    assert run_app(argv) == 0
    img = _png(out)
    assert img.shape == (66, 82, 3)
    expected = region_texture(hm, scale=2, jitter=0.2, seed=3, texture_size=64)
    np.testing.assert_array_equal(img, expected)
    # exists, no --force -> exit 2, file untouched
    before = out.read_bytes()
    assert run_app([*argv[:-1], "--no-slope-rule", "-q"]) == 2
    assert out.read_bytes() == before
    assert run_app([*argv, "--no-slope-rule", "--force"]) == 0
    np.testing.assert_array_equal(
        _png(out), region_texture(hm, scale=2, jitter=0.2, seed=3, texture_size=64,
                                  slope_rule=False))
    assert not list(tmp_path.glob(".*part*"))


def test_regions_command_lightmap(tmp_path, hm_file):
    path, _ = hm_file
    Image.fromarray(np.zeros((5, 5), np.uint8)).save(tmp_path / "dark.png")
    out = tmp_path / "lit.png"
    assert run_app(["texture", "regions", str(path), "-o", str(out), "--lightmap",
                    str(tmp_path / "dark.png"), "-q"]) == 0
    assert _png(out).max() == 0


def test_regions_command_errors(tmp_path, hm_file):
    path, _ = hm_file
    out = tmp_path / "x.png"
    assert run_app(["texture", "regions", str(tmp_path / "none.npy"), "-o", str(out)]) == 2
    assert run_app(["texture", "regions", str(path), "-o", str(out), "--scale", "0"]) == 2
    assert run_app(["texture", "regions", str(path), "-o", str(tmp_path / "x.xyz")]) == 2
    (tmp_path / "bad.png").write_text("nope")
    assert run_app(["texture", "regions", str(path), "-o", str(out), "--lightmap",
                    str(tmp_path / "bad.png")]) == 2
    nan = tmp_path / "nan.npy"
    bad = np.full((5, 5), np.nan, np.float32)  # all nodata (a few NaN are filled, like TIFF)
    np.save(nan, bad)
    assert run_app(["texture", "regions", str(nan), "-o", str(out)]) == 2
    assert not out.exists()
    assert not list(tmp_path.glob(".*part*"))


def test_splat_command_all_or_nothing(tmp_path, hm_file):
    path, hm = hm_file
    prefix = tmp_path / "splat"
    (tmp_path / "splat_1.png").write_bytes(b"keep")
    assert run_app(["texture", "splat", str(path), "-o", str(prefix), "-q"]) == 2
    assert not (tmp_path / "splat_0.png").exists()  # nothing written
    assert (tmp_path / "splat_1.png").read_bytes() == b"keep"
    assert run_app(["texture", "splat", str(path), "-o", str(prefix), "--block", "8",
                    "--force", "-q"]) == 0
    regions = default_regions(hm)
    weights = splat_weights(material_ids_from_rules(hm, regions), 5)
    packed = np.concatenate(pack_splat_maps(weights), axis=-1)  # layer k in channel k
    # Opaque RGB, 3 layers per image: water, sand, grass | rock, snow, (unused).
    for k in range(2):
        img = _png(tmp_path / f"splat_{k}.png")
        assert img.shape == (33, 41, 3)
        layers = packed[..., 3 * k: min(3 * k + 3, 5)]
        np.testing.assert_array_equal(img[..., : layers.shape[-1]], layers)
    assert not _png(tmp_path / "splat_1.png")[..., 2].any()  # only 5 layers
    sums = _png(tmp_path / "splat_0.png").sum(-1, dtype=int) + _png(
        tmp_path / "splat_1.png").sum(-1, dtype=int)
    assert (sums == 255).all()
    # The preview mixes the layer colours by weight, opaque.
    preview = _png(tmp_path / "splat_preview.png").astype(float)
    assert preview.shape == (33, 41, 3)
    colours = np.array([layer_colour(k, r.name) for k, r in enumerate(regions)], float)
    np.testing.assert_allclose(preview, np.tensordot(weights, colours, axes=(0, 0)), atol=0.51)
    only_water = weights[0] > 0.999
    if only_water.any():
        assert (preview[only_water] == colours[0]).all()
    assert run_app(["texture", "splat", str(path), "-o", str(prefix), "--block", "0"]) == 2


def test_material_command(tmp_path):
    out = tmp_path / "rock.png"
    assert run_app(["texture", "material", "rock", "-o", str(out), "--size", "32"]) == 0
    np.testing.assert_array_equal(_png(out), builtin_material("rock", 32))
    assert run_app(["texture", "material", "lava", "-o", str(tmp_path / "l.png")]) == 2


def test_splat_command_with_material_map(tmp_path, hm_file):
    path, _ = hm_file
    ids = np.zeros((32, 40), np.uint8)
    ids[:, 20:] = 2
    Image.fromarray(ids).save(tmp_path / "ids.png")
    prefix = tmp_path / "m"
    assert run_app(["texture", "splat", str(path), "-o", str(prefix), "--materials",
                    str(tmp_path / "ids.png"), "-q"]) == 0
    img = _png(tmp_path / "m_0.png")
    np.testing.assert_array_equal(img, pack_splat_maps(splat_weights(ids, 3))[0][..., :3])
    assert img[5, 0].tolist() == [255, 0, 0] and img[5, 40].tolist() == [0, 0, 255]
    assert not (tmp_path / "m_1.png").exists()
    preview = _png(tmp_path / "m_preview.png")
    assert preview[5, 0].tolist() == list(layer_colour(0))
    assert preview[5, 40].tolist() == list(layer_colour(2))
    assert layer_colour(0) != layer_colour(1) != layer_colour(2)
    # a material map of the vertex size (not the cell size) is a typed error -> exit 2
    Image.fromarray(np.zeros((33, 41), np.uint8)).save(tmp_path / "wrong.png")
    assert run_app(["texture", "splat", str(path), "-o", str(tmp_path / "w"), "--materials",
                    str(tmp_path / "wrong.png")]) == 2
    assert not (tmp_path / "w_0.png").exists()
    Image.fromarray(np.zeros((32, 40, 3), np.uint8)).save(tmp_path / "rgb.png")
    assert run_app(["texture", "splat", str(path), "-o", str(tmp_path / "w"), "--materials",
                    str(tmp_path / "rgb.png")]) == 2


def test_material_command_draws_a_terrain_and_photo_materials(tmp_path, hm_file):
    from terrascape.texture import MaterialRules, material_texture, photo_material

    path, hm = hm_file
    out = tmp_path / "terrain.png"
    flow = np.zeros(hm.shape, np.float32)
    flow[:, 10:12] = 5.0
    np.save(tmp_path / "flow.npy", flow)
    argv = ["texture", "material", str(path), "-o", str(out), "--scale", "2", "--seed", "4",
            "--flow", str(tmp_path / "flow.npy"), "--snow-line", "40", "-q"]
    assert run_app(argv) == 0
    expected = material_texture(hm, masks={"flow": flow}, rules=MaterialRules(snow_line=40.0),
                                scale=2, seed=4)
    np.testing.assert_array_equal(_png(out), expected)
    photo = tmp_path / "grass.png"
    assert run_app(["texture", "material", "photo-grass", "-o", str(photo), "--size", "64"]) == 0
    np.testing.assert_array_equal(_png(photo), photo_material("grass", 64))
    # a NaN mask is one clear error (exit 2) and writes nothing
    flow[0, 0] = np.nan
    np.save(tmp_path / "bad.npy", flow)
    bad = tmp_path / "bad.png"
    assert run_app(["texture", "material", str(path), "-o", str(bad), "--flow",
                    str(tmp_path / "bad.npy"), "-q"]) == 2
    assert not bad.exists()
    assert run_app(["texture", "material", "photo-grass", "-o", str(photo)]) == 2  # exists
