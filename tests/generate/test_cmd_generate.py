"""CLI: ``terrascape generate ...`` and ``terrascape blur`` write what the library computes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from terrascape.cli.app import run_app
from terrascape.filters import box_blur, gaussian_blur
from terrascape.generate import diamond_square, fault_formation, hills
from terrascape.heightmap import Heightmap


def test_diamond_square_cli_matches_library(tmp_path: Path) -> None:
    out = tmp_path / "ds.npy"
    code = run_app(["generate", "diamond-square", "--size", "65", "--seed", "4", "--roughness",
                    "2.5", "--decay", "hurst", "--hurst", "0.7", "--variant", "classic",
                    "--raw", "-o", str(out), "-q"])
    assert code == 0
    ref = diamond_square(65, roughness=2.5, decay="hurst", hurst=0.7, seed=4)
    assert np.load(out).tobytes() == ref.heights.tobytes()


def test_height_scale_and_corners(tmp_path: Path) -> None:
    out = tmp_path / "ds.npy"
    assert run_app(["generate", "diamond-square", "--size", "33", "--corners", "1,2,3,4",
                    "--variant", "classic", "--height-scale", "250", "-o", str(out), "-q"]) == 0
    h = np.load(out)
    assert h.min() == pytest.approx(0.0) and h.max() == pytest.approx(250.0)
    ref = diamond_square(33, corners=(1, 2, 3, 4)).normalised(0.0, 250.0)
    np.testing.assert_array_equal(h, ref.heights)


def test_fault_cli_preview_and_force(tmp_path: Path) -> None:
    out, prev = tmp_path / "f.npy", tmp_path / "f.png"
    argv = ["generate", "fault", "--size", "48x32", "--iterations", "70", "--falloff", "sine",
            "--width", "6", "--seed", "2", "--raw", "-o", str(out), "--preview", str(prev), "-q"]
    assert run_app(argv) == 0
    ref = fault_formation((32, 48), iterations=70, falloff="sine", width=6.0, seed=2)
    assert np.load(out).tobytes() == ref.heights.tobytes()
    assert prev.stat().st_size > 0
    before = out.read_bytes()
    assert run_app([*argv[:-5], "--seed", "3", "-o", str(out), "-q"]) == 2  # exists, no --force
    assert out.read_bytes() == before
    assert run_app([*argv[:-5], "--seed", "3", "-o", str(out), "--force", "-q"]) == 0
    assert out.read_bytes() != before


def test_hills_cli(tmp_path: Path) -> None:
    out = tmp_path / "h.npy"
    assert run_app(["generate", "hills", "--size", "40", "--count", "30", "--radius-min", "2",
                    "--radius-max", "6", "--height", "3", "--seed", "8", "--spacing", "2",
                    "--floor", "--raw", "-o", str(out), "-q"]) == 0
    ref = hills(40, count=30, radius_range=(2.0, 6.0), height=3.0, seed=8)
    assert np.load(out).tobytes() == ref.heights.tobytes()


@pytest.mark.parametrize(
    "argv",
    [
        ["generate", "diamond-square", "--size", "100"],
        ["generate", "diamond-square", "--size", "65x33"],
        ["generate", "diamond-square", "--size", "33", "--decay", "cubic"],
        ["generate", "diamond-square", "--size", "33", "--roughness", "nan"],
        ["generate", "diamond-square", "--size", "33", "--corners", "1,2"],
        ["generate", "fault", "--size", "33", "--falloff", "tanh"],
        ["generate", "fault", "--size", "33", "--iterations", "0"],
        ["generate", "fault", "--size", "abc"],
        ["generate", "hills", "--size", "33", "--radius-min", "-1"],
        ["generate", "hills", "--size", "33", "--height-scale", "-5"],
        ["generate", "hills", "--size", "33", "--count", "x"],
        ["generate", "hills", "--size", "33", "--height-scale", "9", "--raw"],
        ["generate", "diamond-square", "--size", "33", "--variant", "midpoint"],
        ["generate", "diamond-square", "--size", "33", "--integer", "--variant", "square-square"],
        ["generate", "fbm", "--size", "33", "--octaves", "0"],
    ],
)
def test_bad_input_exit_2_and_no_file(tmp_path: Path, argv: list[str]) -> None:
    out = tmp_path / "bad.npy"
    assert run_app([*argv, "-o", str(out), "-q"]) == 2
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # no temp files left either


def test_bad_extension_fails_before_generating(tmp_path: Path) -> None:
    assert run_app(["generate", "hills", "--size", "33", "-o", str(tmp_path / "x.xyz")]) == 2
    assert run_app(["generate", "hills", "--size", "33", "-o", str(tmp_path / "x.npy"),
                    "--preview", str(tmp_path / "p.jpg")]) == 2
    assert list(tmp_path.iterdir()) == []


def test_blur_cli(tmp_path: Path) -> None:
    src = tmp_path / "in.npy"
    h = np.random.default_rng(0).random((20, 30)).astype(np.float32)
    np.save(src, h)
    g, b = tmp_path / "g.npy", tmp_path / "b.npy"
    assert run_app(["blur", str(src), str(g), "--sigma", "1.5", "--mode", "wrap", "-q"]) == 0
    np.testing.assert_array_equal(np.load(g), gaussian_blur(Heightmap(h), 1.5, mode="wrap").heights)
    assert run_app(["blur", str(src), str(b), "--box", "3", "-q"]) == 0
    np.testing.assert_array_equal(np.load(b), box_blur(Heightmap(h), 3).heights)
    assert run_app(["blur", str(src), str(tmp_path / "c.npy"), "-q"]) == 2
    assert run_app(["blur", str(src), str(tmp_path / "c.npy"), "--sigma", "1", "--box", "3"]) == 2
    assert run_app(["blur", str(src), str(tmp_path / "c.npy"), "--sigma", "-1"]) == 2
    assert run_app(["blur", str(src), str(tmp_path / "c.npy"), "--box", "3", "--mode", "x"]) == 2
    assert run_app(["blur", str(tmp_path / "missing.npy"), str(tmp_path / "c.npy"),
                    "--sigma", "1"]) == 2
    assert not (tmp_path / "c.npy").exists()


def test_noise_cli(tmp_path: Path) -> None:
    from terrascape.generate import fbm, ridged

    f, r = tmp_path / "f.npy", tmp_path / "r.npy"
    assert run_app(["generate", "fbm", "--size", "40x24", "--scale", "16", "--octaves", "4",
                    "--seed", "3", "--raw", "-o", str(f), "-q"]) == 0
    ref = fbm((24, 40), scale=16.0, octaves=4, seed=3)
    assert np.load(f).tobytes() == ref.heights.tobytes()
    assert run_app(["generate", "ridged", "--size", "33", "--offset", "1.2", "--seed", "3",
                    "--scale", "128", "--octaves", "6", "--raw", "-o", str(r), "-q"]) == 0
    assert np.load(r).tobytes() == ridged(33, offset=1.2, seed=3).heights.tobytes()
    assert run_app(["generate", "fbm", "--size", "33", "--gain", "2", "-o",
                    str(tmp_path / "x.npy")]) == 2


def test_erode_cli(tmp_path: Path) -> None:
    from terrascape.filters import hydraulic_erosion, thermal_erosion

    src, dst = tmp_path / "in.npy", tmp_path / "out.npy"
    hm = diamond_square(33, roughness=20.0, seed=1)
    np.save(src, hm.heights)
    assert run_app(["erode", str(src), str(dst), "--thermal", "5", "--talus", "40",
                    "--hydraulic", "200", "--seed", "2", "-q"]) == 0
    ref = thermal_erosion(hydraulic_erosion(Heightmap(hm.heights), droplets=200, seed=2),
                          iterations=5, talus_angle=40.0)
    np.testing.assert_array_equal(np.load(dst), ref.heights)
    assert run_app(["erode", str(src), str(tmp_path / "o2.npy"), "--thermal", "-1"]) == 2
    assert not (tmp_path / "o2.npy").exists()
    # no options: the default erosion model, which changes the terrain
    assert run_app(["erode", str(src), str(tmp_path / "o3.npy"), "-q"]) == 0
    assert np.abs(np.load(tmp_path / "o3.npy") - hm.heights).max() > 0.01


def test_default_relief_is_a_fifth_of_the_extent(tmp_path: Path) -> None:
    # No --height-scale: heights span 0 … 20 % of the map's extent, in world units.
    out = tmp_path / "n.npy"
    assert run_app(["generate", "ridged", "--size", "65x33", "--spacing", "3", "-o", str(out),
                    "-q"]) == 0
    h = np.load(out)
    assert h.min() == pytest.approx(0.0, abs=1e-4)
    assert h.max() == pytest.approx(0.2 * 64 * 3.0, rel=1e-5)


def test_cli_equals_registry_with_defaults(tmp_path: Path) -> None:
    from terrascape.generate.registry import generate, generator_names

    for name in generator_names():
        out = tmp_path / f"{name}.npy"
        assert run_app(["generate", name, "--size", "33", "--seed", "5", "--spacing", "2",
                        "-o", str(out), "-q"]) == 0
        ref = generate(name, 33, seed=5, spacing=2.0)
        assert np.load(out).tobytes() == ref.heights.tobytes(), name


def test_erode_masks_and_heightmap_are_one_unit(tmp_path: Path, monkeypatch) -> None:
    """A forced erode whose renames fail half-way (the second of the two kinds of output,
    masks or heightmap, whichever comes second) puts the earlier heightmap and masks back
    byte for byte: never a new heightmap beside old masks, or new masks beside an old one."""
    src, out, masks = tmp_path / "in.npy", tmp_path / "out.npy", tmp_path / "masks"
    masks.mkdir()

    def files() -> dict[str, bytes]:
        return {str(p.relative_to(tmp_path)): p.read_bytes()
                for p in sorted(tmp_path.rglob("*")) if p.is_file() and p != src}

    argv = ["erode", str(src), str(out), "--masks", str(masks), "-q"]
    np.save(src, diamond_square(33, seed=3).scaled(20.0).heights)
    assert run_app(argv) == 0
    before = files()
    assert "out.npy" in before and len(before) > 3
    np.save(src, diamond_square(33, seed=4).scaled(20.0).heights)  # other outputs
    real_replace = os.replace
    renamed: list[str] = []
    failed: list[str] = []

    def replace(source, target, *args, **kwargs):
        name = Path(target).name
        kind = "mask" if Path(target).parent == masks else "heightmap"
        if not failed and name.endswith(".npy") and renamed and renamed[0] != kind:
            failed.append(name)
            raise OSError(28, "No space left on device", str(target))
        if name.endswith(".npy") and kind not in renamed:
            renamed.append(kind)
        return real_replace(source, target, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace)
    assert run_app([*argv, "--force"]) == 1
    monkeypatch.setattr(os, "replace", real_replace)
    assert failed and len(renamed) == 1  # one kind renamed, the other's rename failed
    assert files() == before
    assert not [p for p in tmp_path.rglob("*") if ".part" in p.name or ".bak" in p.name]
    assert run_app([*argv, "--force"]) == 0 and files() != before
