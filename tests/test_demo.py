"""The README's demo command, at small sizes: every file it lists exists and holds what it says."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.cli.demo import run_demo
from terrascape.io import read_heightmap


def test_demo_generate_and_texture_stages(tmp_path):
    result = run_demo(tmp_path, size=65, stages=("generate", "texture"))
    names = {p.name for p, _, _ in result.written}
    for gen in ("diamond_square", "fault", "hills", "fbm", "ridged", "eroded"):
        assert f"{gen}_heightmap.png" in names and f"{gen}_heightmap.r16" in names
        hm = read_heightmap(tmp_path / f"{gen}_heightmap.png")
        assert hm.shape == (65, 65)
        # the registry's default relief (20 % of the extent) survives the 16-bit round trip
        if gen != "eroded":  # erosion moves material after scaling (and uses a 4 m grid)
            assert hm.min == pytest.approx(0.0, abs=0.01)
            assert hm.max == pytest.approx(0.2 * 64 * 2.0, abs=0.01)
        assert float(np.ptp(hm.heights)) > 10.0
    for path, _, _ in result.written:
        assert path.exists() and path.stat().st_size > 0
    top = np.asarray(Image.open(tmp_path / "textured_topdown.png"))
    assert top.ndim == 3 and top.std() > 5  # a picture, not a flat fill
    light = np.asarray(Image.open(tmp_path / "lightmap.png"))
    assert (light >= 250).mean() <= 0.05 and light.min() > 0  # daylight: no clipping, no black
    for mask in ("flow", "deposition", "wear", "water"):
        values = np.load(tmp_path / f"eroded_{mask}.npy")
        assert values.shape == (65, 65) and values.dtype == np.float32
    assert np.load(tmp_path / "eroded_flow.npy").max() > 50  # water gathers into channels
    splat = np.asarray(Image.open(tmp_path / "splat_0.png"))
    assert splat.ndim == 3 and splat.shape[2] == 3  # opaque RGB weights, no hidden alpha
    # different generators give different terrains
    a = read_heightmap(tmp_path / "fault_heightmap.png").heights
    b = read_heightmap(tmp_path / "hills_heightmap.png").heights
    assert not np.allclose(a, b)


def test_demo_is_deterministic(tmp_path):
    run_demo(tmp_path / "a", size=33, stages=("generate",))
    run_demo(tmp_path / "b", size=33, stages=("generate",))
    for f in (tmp_path / "a").iterdir():
        assert f.read_bytes() == (tmp_path / "b" / f.name).read_bytes(), f.name


def test_demo_refuses_to_overwrite_without_force(tmp_path):
    run_demo(tmp_path, size=33, stages=("generate",))
    assert run_app(["demo", "-o", str(tmp_path), "--size", "33", "--stages", "generate"]) == 2
    assert run_app(["demo", "-o", str(tmp_path), "--size", "33", "--stages", "generate",
                    "--force"]) == 0


def test_demo_bad_size_is_a_usage_error(tmp_path):
    assert run_app(["demo", "-o", str(tmp_path), "--size", "3"]) == 2
    assert not any(tmp_path.iterdir())


@pytest.mark.gl
def test_demo_render_stage(tmp_path, gl_ctx):
    result = run_demo(tmp_path, size=65, render_size=(160, 90),
                      stages=("generate", "render"))
    assert not result.skipped, result.skipped
    renders = sorted(tmp_path.glob("render_*_closeup.png"))
    assert len(renders) >= 10
    images = {p.name: np.asarray(Image.open(p)).astype(int) for p in renders}
    plain = images["render_plain_closeup.png"]
    assert plain.shape == (90, 160, 3)
    # every technique draws terrain (not just sky) and differs from at least the plain one
    for name, img in images.items():
        assert img.std() > 3, name
        if name != "render_plain_closeup.png" and "texture3d" not in name:
            assert np.abs(img - plain).mean() > 0.5, name
    # the showcase: real pictures, with water where the sea is, no black shadows
    for name in ("showcase_golden_hour.png", "showcase_coast.png", "showcase_map.png",
                 "showcase_forest.png"):
        img = np.asarray(Image.open(tmp_path / name)).astype(int)
        assert img.shape == (90, 160, 3) and img.std() > 5, name
        assert (img.max(axis=-1) < 8).mean() < 0.001, name
    # the forest is the coast with objects on it: they show
    coast = np.asarray(Image.open(tmp_path / "showcase_coast.png")).astype(int)
    forest = np.asarray(Image.open(tmp_path / "showcase_forest.png")).astype(int)
    assert (np.abs(forest - coast).max(axis=-1) > 12).mean() > 0.002
    # dusk: the sky of that moment, its glow warm in the north-west (left), cooler in the
    # north-east (right)
    dusk = np.asarray(Image.open(tmp_path / "showcase_dusk.png")).astype(int)
    assert dusk.shape == (90, 160, 3) and dusk.std() > 5
    west, east = (dusk[:20, cols].reshape(-1, 3).mean(axis=0)
                  for cols in (slice(0, 40), slice(-40, None)))
    assert west[0] > west[2] + 20 and west[0] - west[2] > east[0] - east[2] + 15, (west, east)
    top = np.asarray(Image.open(tmp_path / "showcase_map.png")).astype(int)
    bluish = (top[..., 2] > top[..., 0] + 15).mean()
    assert bluish > 0.05  # the sea around and on the terrain
    roam = np.asarray(Image.open(tmp_path / "lod_roam_wireframe.png")).astype(int)
    assert roam.shape == (90, 160, 3)
    assert (tmp_path / "lod_roam.obj").read_text().count("\nf ") > 100
