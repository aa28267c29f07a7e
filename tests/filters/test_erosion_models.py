"""The default erosion drains like real terrain on a small fBm map; every model returns the
four masks; ``terrascape erode`` runs with no options and writes masks atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from terrascape.analysis.drainage import drainage_statistics
from terrascape.cli.app import run_app
from terrascape.errors import InvalidParameterError
from terrascape.filters import MASK_NAMES, MODELS, erode
from terrascape.generate import fbm
from terrascape.heightmap import Heightmap


@pytest.fixture(scope="module")
def raw() -> Heightmap:
    # 257² at 4 m with 75 m of relief: the 1025² / 300 m bench terrain scaled down.
    return fbm(257, scale=64.0, octaves=6, seed=11, spacing=4.0).normalised(0, 75)


@pytest.fixture(scope="module")
def default(raw: Heightmap):
    return erode(raw)


def test_default_erosion_drains_like_real_terrain(raw: Heightmap, default) -> None:
    before = drainage_statistics(raw)
    after = drainage_statistics(default.heightmap)
    assert before.depression_share > 0.15  # fBm: lakes everywhere
    assert after.depression_share <= 0.10
    assert 0.40 <= after.beta <= 0.55
    # Flow concentrates in channels: the top 1 % of samples carry most of the drainage.
    flow = np.sort(default.masks["flow"].ravel())[::-1]
    assert flow[: flow.size // 100].sum() > 0.5 * flow.sum()
    # It changed the map visibly but kept its relief (valleys cut, ridges kept).
    dh = default.heightmap.heights - raw.heights
    assert np.abs(dh).mean() > 0.005 * 75
    assert default.heightmap.max > 0.8 * raw.max


def test_default_erosion_is_deterministic(raw: Heightmap, default) -> None:
    again = erode(raw)
    assert again.heightmap.heights.tobytes() == default.heightmap.heights.tobytes()
    for name in MASK_NAMES:
        assert again.masks[name].tobytes() == default.masks[name].tobytes()


def test_masks_mean_what_they_say(raw: Heightmap, default) -> None:
    dh = default.heightmap.heights.astype(np.float64) - raw.heights
    m = default.masks
    assert set(m) == set(MASK_NAMES)
    for mask in m.values():
        assert mask.dtype == np.float32 and mask.shape == raw.shape
    np.testing.assert_allclose(m["deposition"] - m["wear"], dh, atol=1e-4)
    assert (m["deposition"] >= 0).all() and (m["wear"] >= 0).all()
    # Wear is on the channels: mean flow where it wore most beats the map's mean flow.
    deep = m["wear"] > np.percentile(m["wear"], 99)
    assert m["flow"][deep].mean() > 10 * m["flow"].mean()


@pytest.mark.parametrize("model", [m for m in MODELS if m != "stream-power"])
def test_every_model_gives_the_masks(raw: Heightmap, model: str) -> None:
    small = Heightmap(raw.heights[:65, :65], raw.spacing)
    res = erode(small, model=model, iterations=20 if model != "droplets" else 500)
    assert set(res.masks) == set(MASK_NAMES)
    assert not np.array_equal(res.heightmap.heights, small.heights)
    assert res.masks["flow"].max() > 1.0
    if model == "grid":
        assert res.masks["water"].max() > 0


def test_bad_model_and_strength(raw: Heightmap) -> None:
    with pytest.raises(InvalidParameterError, match="model"):
        erode(raw, model="glaciers")
    with pytest.raises(InvalidParameterError, match="strength"):
        erode(raw, strength=-1)


def test_cli_erode_without_options_and_masks(tmp_path: Path) -> None:
    hm = fbm(65, scale=16.0, octaves=5, seed=2, spacing=4.0).normalised(0, 20)
    src, dst, masks = tmp_path / "in.npy", tmp_path / "out.npy", tmp_path / "masks"
    np.save(src, hm.heights)
    assert run_app(["erode", str(src), str(dst), "-q"]) == 0
    ref = erode(Heightmap(hm.heights))
    np.testing.assert_array_equal(np.load(dst), ref.heightmap.heights)
    masks.mkdir()
    out2 = tmp_path / "grid.tif"
    assert run_app(["erode", str(src), str(out2), "--model", "grid", "--iterations", "40",
                    "--masks", str(masks), "-q"]) == 0
    grid = erode(Heightmap(hm.heights), model="grid", iterations=40)
    for name in MASK_NAMES:
        saved = np.load(masks / f"{name}.npy")
        assert saved.dtype == np.float32
        np.testing.assert_array_equal(saved, grid.masks[name])
    # --deposition 0: the river erosion without fans
    bare = tmp_path / "bare.npy"
    assert run_app(["erode", str(src), str(bare), "--deposition", "0", "-q"]) == 0
    np.testing.assert_array_equal(
        np.load(bare), erode(Heightmap(hm.heights), deposition=0.0).heightmap.heights)
    assert not np.array_equal(np.load(bare), np.load(dst))
    # Existing masks are not overwritten without --force, and nothing else is written.
    out3 = tmp_path / "again.npy"
    assert run_app(["erode", str(src), str(out3), "--masks", str(masks), "-q"]) == 2
    assert not out3.exists()
    assert run_app(["erode", str(src), str(out3), "--masks", str(masks), "--force",
                    "-q"]) == 0
    assert out3.exists()


@pytest.mark.parametrize(
    "args",
    [
        ["--model", "lava"],
        ["--model", "grid", "--strength", "-2"],
        ["--iterations", "-3"],
        ["--masks", "no-such-folder"],
        ["--model", "grid", "--rain", "-0.5"],
        ["--model", "grid", "--dt", "5"],
        ["--model", "grid", "--evaporation", "100"],
        ["--model", "grid", "--deposition", "1"],
        ["--deposition", "-1"],
    ],
)
def test_cli_bad_input_writes_nothing(tmp_path: Path, args: list[str]) -> None:
    src, dst = tmp_path / "in.npy", tmp_path / "out.npy"
    np.save(src, fbm(33, scale=8.0, octaves=3, seed=1).heights)
    assert run_app(["erode", str(src), str(dst), *args, "-q"]) == 2
    assert not dst.exists()


def test_cli_nan_maps_refused(tmp_path: Path) -> None:
    src, dst, rain = tmp_path / "in.npy", tmp_path / "out.npy", tmp_path / "rain.npy"
    np.save(src, fbm(33, scale=8.0, octaves=3, seed=1).heights)
    bad = np.full((33, 33), 0.01, dtype=np.float32)
    bad[4, 4] = np.nan
    np.save(rain, bad)
    assert run_app(["erode", str(src), str(dst), "--model", "grid", "--rain-map", str(rain),
                    "-q"]) == 2
    np.save(rain, -bad[:, :] * 0 - 0.5)
    assert run_app(["erode", str(src), str(dst), "--model", "grid", "--rain-map", str(rain),
                    "-q"]) == 2
    assert not dst.exists()
