"""Worlds built chunk by chunk on a dask cluster equal the whole-map functions bit for bit."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
import zarr

from terrascape.errors import (
    EnvironmentFailure,
    FileFormatError,
    InvalidParameterError,
    OutputExistsError,
)
from terrascape.filters.thermal_erosion import thermal_erosion
from terrascape.generate.noise import fbm, ridged
from terrascape.heightmap import Heightmap
from terrascape.lighting.normals import normal_map
from terrascape.lighting.shadows import shadow_mask
from terrascape.world import build_world, connect, load_recipe, recipe_from_dict, world_info

ROWS, COLS = 230, 190  # not multiples of the chunk sizes: ragged last chunks


@pytest.fixture(scope="module")
def client():
    # Threads of this process: quick to start; numba kernels hold the GIL, which is fine for
    # correctness (the benchmark uses processes).
    with connect("local", workers=2, processes=False, memory_limit=None) as c:
        yield c


def _recipe(chunk: int, generator: str = "fbm", *, seed: int = 5, azimuth: float = 100.0,
            iterations: int = 3) -> dict:
    return {"size": [ROWS, COLS], "spacing": 1.5, "seed": seed, "chunk": chunk,
            "generator": {"name": generator, "relief": 45.0, "scale": 60.0, "octaves": 6},
            "thermal": {"iterations": iterations, "talus": 28.0},
            "normals": {"height_scale": 1.0},
            "shadow": {"azimuth": azimuth, "elevation": 22.0}}


def _whole_map(recipe) -> dict[str, np.ndarray]:
    sp = (recipe.spacing, recipe.spacing)
    fn = fbm if recipe.generator == "fbm" else ridged
    raw = fn(recipe.shape, amplitude=recipe.relief, seed=recipe.seed, spacing=sp,
             **recipe.params)
    eroded = thermal_erosion(raw, iterations=recipe.thermal["iterations"],
                             talus_angle=recipe.thermal["talus"], rate=recipe.thermal["rate"])
    hm = Heightmap(eroded.heights, sp)
    return {"height_raw": raw.heights, "height": eroded.heights,
            "normals": normal_map(hm, height_scale=1.0),
            "shadow": shadow_mask(hm, recipe.shadow["azimuth"],
                                  recipe.shadow["elevation"]).astype(np.uint8)}


def _chunk_files(path: Path) -> dict[str, bytes]:
    """Every stored chunk file's bytes (the zarr metadata excluded)."""
    return {str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*"))
            if p.is_file() and p.name != "zarr.json"}


@pytest.mark.parametrize(("chunk", "generator", "azimuth"),
                         [(64, "fbm", 100.0), (96, "ridged", 200.0), (128, "fbm", 333.0)])
def test_tiled_world_equals_whole_map(client, tmp_path, chunk, generator, azimuth):
    recipe = recipe_from_dict(_recipe(chunk, generator, azimuth=azimuth))
    result = build_world(recipe, tmp_path / "w.zarr", client=client)
    assert result.complete
    group = zarr.open_group(str(tmp_path / "w.zarr"), mode="r")
    whole = _whole_map(recipe)
    for name, expected in whole.items():
        got = np.asarray(group[name][...])
        assert got.dtype == expected.dtype, name
        assert np.array_equal(got, expected), f"{name}: {np.sum(got != expected)} samples differ"
    # Something to compare: eroded differs from raw, the map has lit and shadowed samples.
    assert not np.array_equal(whole["height"], whole["height_raw"])
    assert 0.05 < whole["shadow"].mean() < 0.95
    # Pyramid: every other sample of the level above.
    level = whole["height"]
    k = 1
    while max(level.shape) > chunk:
        level = level[::2, ::2]
        assert np.array_equal(np.asarray(group[f"levels/{k}"][...]), level)
        k += 1
    assert group.attrs["levels"] == k - 1 >= 1
    assert json.loads(group.attrs["recipe"]) == recipe.to_dict()
    assert group.attrs["recipe_hash"] == recipe.digest()


def test_one_sample_last_chunks(client, tmp_path):
    data = _recipe(64)
    data["size"] = [129, 193]  # last chunk row and column are 1 sample wide
    recipe = recipe_from_dict(data)
    assert build_world(recipe, tmp_path / "w.zarr", client=client).complete
    group = zarr.open_group(str(tmp_path / "w.zarr"), mode="r")
    for name, expected in _whole_map(recipe).items():
        assert np.array_equal(np.asarray(group[name][...]), expected), name


def test_halo_is_needed(client, tmp_path):
    """The halos matter: the same chunks computed without them differ at chunk edges."""
    from terrascape.world.stages import chunk_bounds

    recipe = recipe_from_dict(_recipe(64))
    whole = _whole_map(recipe)
    raw = whole["height_raw"]
    r0, r1, c0, c1 = chunk_bounds(recipe.shape, 64, 1, 1)
    alone = thermal_erosion(Heightmap(raw[r0:r1, c0:c1], (1.5, 1.5)), iterations=3,
                            talus_angle=28.0).heights
    assert not np.array_equal(alone, whole["height"][r0:r1, c0:c1])
    sm = shadow_mask(Heightmap(whole["height"][r0:r1, c0:c1], (1.5, 1.5)), 100.0, 22.0)
    assert not np.array_equal(sm, whole["shadow"][r0:r1, c0:c1].astype(bool))


def test_resume_after_stop_and_corruption_gives_same_bytes(client, tmp_path):
    recipe = recipe_from_dict(_recipe(64, seed=9))
    reference = tmp_path / "ref.zarr"
    build_world(recipe, reference, client=client)
    expected = _chunk_files(reference)

    partial = tmp_path / "part.zarr"
    first = build_world(recipe, partial, client=client, max_chunks=17)
    assert not first.complete and first.written == 17
    assert world_info(partial).complete is False
    second = build_world(recipe, partial, client=client, max_chunks=9)
    assert second.skipped == 17 and second.written == 9 and not second.complete
    third = build_world(recipe, partial, client=client)
    assert third.complete and third.skipped == 26
    assert _chunk_files(partial) == expected

    # A chunk whose data was damaged after it was marked done is not detected (markers are
    # trusted) — but one killed between data and marker is redone: emulate that by
    # clearing markers and writing garbage into those chunks.
    group = zarr.open_group(str(partial), mode="r+")
    for name in ("height_raw", "height", "shadow"):
        group[f"done/{name}"][1, 2] = 0
        group[f"done/{name}"][3, 0] = 0
    group["height_raw"][64:128, 128:190] = np.float32(np.nan)
    group["height"][192:230, 0:64] = np.float32(-1e9)
    group["shadow"][64:128, 128:190] = 7
    fourth = build_world(recipe, partial, client=client)
    assert fourth.written == 6 and fourth.complete
    assert _chunk_files(partial) == expected


def test_other_recipe_is_refused_never_mixed(client, tmp_path):
    path = tmp_path / "w.zarr"
    build_world(recipe_from_dict(_recipe(64, iterations=1)), path, client=client,
                max_chunks=3)
    other = recipe_from_dict(_recipe(64, iterations=2))
    with pytest.raises(OutputExistsError, match="another recipe"):
        build_world(other, path, client=client)
    result = build_world(other, path, client=client, force=True)
    assert result.complete and result.skipped == 0
    assert world_info(path).recipe == other
    junk = tmp_path / "junk"
    junk.mkdir()
    with pytest.raises(OutputExistsError, match="not a terrascape world"):
        build_world(other, junk, client=client)


@pytest.mark.parametrize(("change", "match"), [
    ({"colour": 3}, "'colour'"),
    ({"generator": {"name": "fbm", "octavez": 3}}, "octavez"),
    ({"generator": {"name": "hills"}}, "generator.name"),
    ({"size": [2, 100]}, "'size'"),
    ({"size": [100]}, "'size'"),
    ({"chunk": 8}, "'chunk'"),
    ({"spacing": -1.0}, "'spacing'"),
    ({"thermal": {"iterations": 40}}, "thermal.iterations"),
    ({"thermal": {"talus": 95}}, "thermal.talus"),
    ({"shadow": {"elevation": 0}}, "shadow.elevation"),
    ({"shadow": {"sun": 3}}, "shadow.'sun'"),
    ({"seed": 1.5}, "'seed'"),
])
def test_recipe_errors_name_the_key(change, match):
    data = _recipe(64)
    data.update(change)
    with pytest.raises(InvalidParameterError, match=match):
        recipe_from_dict(data)


def test_recipe_files(tmp_path):
    toml = tmp_path / "r.toml"
    toml.write_text('size = 129\nchunk = 64\n[generator]\nname = "ridged"\nscale = 30\n'
                    "[shadow]\n")
    recipe = load_recipe(toml)
    assert recipe.shape == (129, 129) and recipe.params["scale"] == 30.0
    assert recipe.shadow == {"azimuth": 135.0, "elevation": 30.0}
    js = tmp_path / "r.json"
    js.write_text(json.dumps(recipe.to_dict()))
    assert load_recipe(js).digest() == recipe.digest()
    switched = recipe_from_dict({**recipe.to_dict(), "normals": True, "shadow": False})
    assert switched.normals == {"height_scale": 1.0} and switched.shadow is None
    bad = tmp_path / "bad.toml"
    bad.write_text("size = [1, \n")
    with pytest.raises(FileFormatError, match="not valid TOML"):
        load_recipe(bad)


def test_unreachable_scheduler_fails_fast():
    start = time.perf_counter()
    with pytest.raises(EnvironmentFailure, match="no dask scheduler answers"), \
            connect("tcp://127.0.0.1:9", timeout=1.0):
        pass
    assert time.perf_counter() - start < 15.0


def test_bad_cluster_options():
    with pytest.raises(InvalidParameterError, match="--memory-limit"), \
            connect("local", workers=1, memory_limit="lots"):
        pass
    with pytest.raises(InvalidParameterError, match="--workers"), connect("local", workers=0):
        pass


def test_cli_build_and_info(tmp_path):
    from typer.testing import CliRunner

    from terrascape.cli import app

    recipe = tmp_path / "r.toml"
    recipe.write_text('size = [100, 80]\nchunk = 64\nseed = 2\n[generator]\nname = "fbm"\n'
                      "[normals]\n")
    runner = CliRunner()
    store = tmp_path / "w.zarr"
    res = runner.invoke(app, ["world", "build", str(recipe), "-o", str(store), "--workers",
                              "1", "--threads", "--quiet"])
    assert res.exit_code == 0, res.output
    group = zarr.open_group(str(store), mode="r")
    r = load_recipe(recipe)
    expected = fbm(r.shape, amplitude=r.relief, seed=2, **r.params).heights
    assert np.array_equal(np.asarray(group["height"][...]), expected)
    res = runner.invoke(app, ["world", "info", str(store)])
    assert res.exit_code == 0
    assert "100 rows × 80 cols" in res.output and "complete" in res.output
    assert "levels/1" in res.output and '"seed":2' in res.output


def test_cli_errors_are_one_line(tmp_path, capsys):
    from terrascape.cli.app import run_app

    assert run_app(["world", "info", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "not a terrascape world" in err and "Traceback" not in err
    bad = tmp_path / "r.toml"
    bad.write_text('size = 100\n[generator]\nname = "fbm"\nwidth = 3\n')
    assert run_app(["world", "build", str(bad), "-o", str(tmp_path / "w.zarr")]) == 2
    assert "width" in capsys.readouterr().err



@pytest.mark.timeout(120)
def test_threaded_workers_build_whatever_this_process_holds(tmp_path):
    """Workers that are threads of this process share its memory, so the per-worker limit
    does not apply to them: a process that already holds more than 80 % of it (here any
    process: 64 MB) still builds. Dask paused such workers, and the build waited for ever
    (a test process after some 1800 tests did)."""
    import psutil

    assert psutil.Process().memory_info().rss > 0.8 * 64e6
    recipe = recipe_from_dict({"size": [130, 130], "chunk": 64, "seed": 2,
                               "generator": {"name": "fbm", "relief": 10.0, "scale": 40.0}})
    with connect("local", workers=1, processes=False, memory_limit="64MB") as client:
        assert build_world(recipe, tmp_path / "w.zarr", client=client, quiet=True).complete


def test_a_worker_process_is_one_core(tmp_path):
    """In worker processes a build's tasks decode with a zarr codec pool of one thread, and
    the workers' profiler is off."""
    recipe = recipe_from_dict({"size": [130, 130], "chunk": 64, "seed": 2,
                               "generator": {"name": "fbm", "relief": 10.0, "scale": 40.0}})
    with connect("local", workers=2, processes=True, memory_limit=None) as client:
        assert build_world(recipe, tmp_path / "w.zarr", client=client).complete
        # Lambdas travel by value (the workers cannot import this test module).
        pools = client.run(lambda: __import__("zarr.core.sync", fromlist=["x"])
                           ._executor._max_workers)
        profile = client.run(lambda: __import__("dask").config.get(
            "distributed.worker.profile.enabled"))
    assert len(pools) == 2 and all(v == 1 for v in pools.values()), pools
    assert all(v is False for v in profile.values()), profile


def test_a_new_store_appears_whole_or_not_at_all(tmp_path, monkeypatch):
    """A store is made in a hidden folder and renamed into place once its arrays and recipe
    are written: interrupted while it is made, nothing is left (a half-made store was "not a
    terrascape world" to the next run, which asked for --force); and a second build of the
    same recipe that made the store meanwhile is joined, not refused."""
    import signal

    import terrascape.world.store as store
    from terrascape.errors import Interrupted

    recipe = recipe_from_dict({"size": [40, 50], "seed": 1, "chunk": 32,
                               "generator": {"name": "fbm"}})
    path = tmp_path / "w.zarr"
    add = store._add_missing_arrays
    calls = [0]

    def interrupted(group, r):
        add(group, r)
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(store, "_add_missing_arrays", interrupted)
    with pytest.raises(Interrupted):
        store.create_or_resume(path, recipe)
    assert list(tmp_path.iterdir()) == []

    def another_build_meanwhile(group, r):
        add(group, r)
        calls[0] += 1
        if calls[0] == 1:
            monkeypatch.setattr(store, "_add_missing_arrays", add)
            theirs = store.create_or_resume(path, recipe)
            theirs["done/height"][0, 0] = 1  # their first finished chunk

    monkeypatch.setattr(store, "_add_missing_arrays", another_build_meanwhile)
    group = store.create_or_resume(path, recipe)
    assert group.attrs["recipe_hash"] == recipe.digest()
    assert group["done/height"][0, 0] == 1  # theirs, resumed
    assert [p.name for p in tmp_path.iterdir()] == ["w.zarr"]
    assert (path.stat().st_mode & 0o777) == 0o777 & ~_umask()


def _umask() -> int:
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_a_build_that_cannot_start_leaves_no_new_store(tmp_path, monkeypatch):
    """A scheduler that does not answer (or a signal while the cluster starts) leaves no
    store the build just made; a store that was there already stays, resumable."""
    import terrascape.world.build as build
    from terrascape.errors import EnvironmentFailure

    def unreachable(*args, **kwargs):
        raise EnvironmentFailure("no dask scheduler answers at tcp://127.0.0.1:1 within 5 s")

    recipe = recipe_from_dict({"size": [40, 50], "seed": 1, "chunk": 32,
                               "generator": {"name": "fbm"}})
    path = tmp_path / "w.zarr"
    with monkeypatch.context() as m:
        m.setattr(build, "connect", unreachable)
        with pytest.raises(EnvironmentFailure):
            build_world(recipe, path, scheduler="tcp://127.0.0.1:1")
        assert list(tmp_path.iterdir()) == []
    assert not build_world(recipe, path, processes=False, max_chunks=1).complete
    with monkeypatch.context() as m:
        m.setattr(build, "connect", unreachable)
        with pytest.raises(EnvironmentFailure):
            build_world(recipe, path, scheduler="tcp://127.0.0.1:1")
    assert build_world(recipe, path, processes=False).complete
