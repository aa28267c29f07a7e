"""Hydraulic erosion in a tiled world: grid (virtual pipes) and droplets, equal bit for bit to
their untiled runs, for several chunk sizes, and resumable in the middle of the droplet
phases."""

from __future__ import annotations

import numpy as np
import pytest
import zarr

from terrascape.errors import InvalidParameterError
from terrascape.filters.thermal_erosion import thermal_erosion
from terrascape.filters.virtual_pipe_erosion import virtual_pipe_erosion
from terrascape.generate.noise import fbm
from terrascape.world import build_world, connect, recipe_from_dict
from terrascape.world.droplets import chunk_droplet_starts, droplet_reference, phase

ROWS, COLS = 230, 190


@pytest.fixture(scope="module")
def client():
    with connect("local", workers=2, processes=False, memory_limit=None) as c:
        yield c


def _recipe(chunk: int, erosion: dict, *, thermal: bool = False) -> dict:
    data = {"size": [ROWS, COLS], "spacing": 1.5, "seed": 5, "chunk": chunk,
            "generator": {"name": "fbm", "relief": 45.0, "scale": 60.0, "octaves": 6},
            "erosion": erosion}
    if thermal:
        data["thermal"] = {"iterations": 2, "talus": 28.0}
    return data


def _raw(recipe):
    return fbm(recipe.shape, amplitude=recipe.relief, seed=recipe.seed,
               spacing=(recipe.spacing, recipe.spacing), **recipe.params)


def _stored(path, name="height"):
    return np.asarray(zarr.open_group(str(path), mode="r")[name][...])


@pytest.mark.parametrize("chunk", [64, 96])
def test_grid_erosion_world_equals_whole_map(client, tmp_path, chunk):
    recipe = recipe_from_dict(_recipe(chunk, {"model": "grid", "iterations": 12},
                                      thermal=True))
    assert build_world(recipe, tmp_path / "w.zarr", client=client).complete
    raw = _raw(recipe)
    eroded = virtual_pipe_erosion(raw, iterations=12).heightmap
    final = thermal_erosion(eroded, iterations=2, talus_angle=28.0)
    assert np.array_equal(_stored(tmp_path / "w.zarr", "height_eroded"), eroded.heights)
    assert np.array_equal(_stored(tmp_path / "w.zarr"), final.heights)
    assert np.abs(eroded.heights - raw.heights).max() > 0.05  # the water did something


@pytest.mark.parametrize("chunk", [80, 112])
def test_droplet_world_equals_untiled_run(client, tmp_path, chunk):
    recipe = recipe_from_dict(_recipe(chunk, {"model": "droplets"}))
    assert build_world(recipe, tmp_path / "w.zarr", client=client).complete
    raw = _raw(recipe).heights
    expected = droplet_reference(raw, recipe)
    got = _stored(tmp_path / "w.zarr")
    assert np.array_equal(got, expected), f"{np.sum(got != expected)} samples differ"
    change = np.abs(expected - raw)
    assert change.mean() > 0.1 and change.max() > 1.0  # real erosion, not a copy
    # Height is conserved (what droplets take they put down somewhere on the map).
    assert abs(float(got.sum(dtype=np.float64)) - float(raw.sum(dtype=np.float64))) \
        < 1e-6 * float(np.abs(raw).sum())
    # The droplets start in their chunk's core and cover the map.
    starts = chunk_droplet_starts(recipe, 1, 1)
    r1, c1 = min(2 * chunk, ROWS), min(2 * chunk, COLS)
    assert len(starts) == (r1 - chunk) * (c1 - chunk)
    assert starts[:, 0].min() >= chunk and starts[:, 0].max() < c1
    assert starts[:, 1].min() >= chunk and starts[:, 1].max() < r1


def test_droplet_phases_matter_and_resume_mid_phase(client, tmp_path):
    """Stopped inside the droplet phases and continued: the same bytes. And the phases are
    needed: every chunk run on the raw heights at once (one phase) gives another map."""
    recipe = recipe_from_dict(_recipe(80, {"model": "droplets", "density": 0.5}))
    ref = tmp_path / "ref.zarr"
    build_world(recipe, ref, client=client)
    part = tmp_path / "part.zarr"
    # height_raw has 9 chunks; 9 + 4 stops within the droplet phases (phase 0: 4 chunks,
    # phase 1: 2, ...), 9 + 5 inside phase 1.
    for stop in (13, 1):
        r = build_world(recipe, part, client=client, max_chunks=stop)
        assert not r.complete
    done = np.asarray(zarr.open_group(str(part), mode="r")["done/droplet_window"][...])
    assert done.sum() == 5
    assert {phase(i, j) for i, j in zip(*done.nonzero(), strict=True)} == {0, 1}
    assert build_world(recipe, part, client=client).complete
    assert np.array_equal(_stored(part), _stored(ref))

    from terrascape.filters.hydraulic_erosion import droplets_in_window

    raw = _raw(recipe).heights
    one_phase = raw.astype(np.float64)
    delta = np.zeros_like(one_phase)
    for i in range(3):
        for j in range(3):
            h = raw.astype(np.float64)
            droplets_in_window(h, chunk_droplet_starts(recipe, i, j), max_steps=30, radius=3.0)
            delta += h - one_phase
    assert not np.array_equal((one_phase + delta).astype(np.float32), _stored(ref))


@pytest.mark.parametrize(("erosion", "match"), [
    ({"model": "stream-power"}, "does not tile"),
    ({"model": "rain"}, "erosion.model"),
    ({"model": "grid", "iterations": 30}, "halo of 90"),
    ({"model": "droplets", "max_steps": 40}, "more than half the chunk"),
    ({"model": "droplets", "wind": 2}, "erosion.'wind'"),
    ({"model": "grid", "rain": -1}, "erosion.rain"),
])
def test_erosion_recipe_errors(erosion, match):
    with pytest.raises(InvalidParameterError, match=match):
        recipe_from_dict(_recipe(64, erosion))


def test_droplets_in_window_rejects_bad_input():
    from terrascape.filters.hydraulic_erosion import droplets_in_window

    h = np.zeros((10, 10))
    with pytest.raises(InvalidParameterError, match="float64"):
        droplets_in_window(h.astype(np.float32), np.zeros((1, 3)))
    with pytest.raises(InvalidParameterError, match="inside the window"):
        droplets_in_window(h, np.array([[12.0, 1.0, 0.0]]), (0, 0))
    with pytest.raises(InvalidParameterError, match=r"\(n, 3\)"):
        droplets_in_window(h, np.zeros((2, 2)))
