"""Exports from a world, one dask task per tile: the same bytes as one process, read back
by rasterio and by decoding the tiles, equal to the exporters of the map loaded whole."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import zarr
from PIL import Image

from terrascape.errors import InvalidParameterError
from terrascape.export import ExportOptions, get_destination
from terrascape.heightmap import Heightmap
from terrascape.world import build_world, connect, recipe_from_dict
from terrascape.world.export import (
    export_cog,
    export_geotiff,
    export_quantized_mesh,
    export_terrain_rgb,
)

LONLAT = (15.0, 45.0)


@pytest.fixture(scope="module")
def client():
    with connect("local", workers=2, processes=False, memory_limit=None) as c:
        yield c


@pytest.fixture(scope="module")
def world(tmp_path_factory, client) -> Path:
    path = tmp_path_factory.mktemp("world") / "w.zarr"
    recipe = recipe_from_dict({
        "size": [300, 257], "spacing": 2.0, "seed": 8, "chunk": 64,
        "generator": {"name": "ridged", "relief": 80.0, "scale": 90.0, "octaves": 5}})
    assert build_world(recipe, path, client=client).complete
    return path


def _heights(path):
    return np.asarray(zarr.open_group(str(path), mode="r")["height"][...])


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _decode_mapbox(path: Path) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(Image.open(path)).astype(np.float64)
    return -10000.0 + (a[..., 0] * 65536 + a[..., 1] * 256 + a[..., 2]) * 0.1, a[..., 3] > 0


def test_geotiff_parallel_equals_serial_and_reads_back(world, client, tmp_path):
    import rasterio

    serial = export_geotiff(world, tmp_path / "serial.tif")
    parallel = export_geotiff(world, tmp_path / "parallel.tif", client=client)
    assert serial.read_bytes() == parallel.read_bytes()
    with rasterio.open(parallel) as src:
        assert np.array_equal(src.read(1), _heights(world))
        assert src.block_shapes == [(512, 512)] or src.block_shapes == [(256, 256)] or \
            src.profile["tiled"]
        assert src.compression.name == "deflate"
        assert src.transform.a == 2.0 and src.transform.e == -2.0
    with pytest.raises(Exception, match="exists"):
        export_geotiff(world, tmp_path / "serial.tif")


def test_cog_parallel_equals_serial_is_valid_and_equals_the_store(client, tmp_path):
    import rasterio
    from rio_cogeo.cogeo import cog_validate

    # Sides that halve exactly, so each overview sample is the mean of 2 × 2 below it.
    recipe = recipe_from_dict({
        "size": [256, 384], "spacing": 2.0, "seed": 8, "chunk": 64,
        "generator": {"name": "ridged", "relief": 80.0, "scale": 90.0, "octaves": 5}})
    store = tmp_path / "w.zarr"
    assert build_world(recipe, store, client=client).complete
    serial = export_cog(store, tmp_path / "serial.tif", blocksize=64)
    parallel = export_cog(store, tmp_path / "parallel.tif", client=client, blocksize=64)
    assert serial.read_bytes() == parallel.read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["parallel.tif", "serial.tif",
                                                            "w.zarr"]  # no leftovers
    valid, errors, warns = cog_validate(str(parallel))
    assert valid and not errors and not warns, (errors, warns)
    h = _heights(store)
    with rasterio.open(parallel) as src:
        assert src.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert src.block_shapes == [(64, 64)] and src.overviews(1) == [2, 4, 8]
        assert src.transform.a == 2.0 and src.transform.e == -2.0 and src.crs is None
        assert src.tags()["terrascape_world"] == recipe.digest()
        assert np.array_equal(src.read(1), h)
    mean = h.astype(np.float64)
    for level in range(3):
        mean = mean.reshape(mean.shape[0] // 2, 2, mean.shape[1] // 2, 2).mean(axis=(1, 3))
        with rasterio.open(parallel, OVERVIEW_LEVEL=level) as ov:
            got = ov.read(1)
        if level == 0:
            np.testing.assert_allclose(got, mean, atol=1e-4)
        else:  # GDAL averages each overview from the one above it (float32)
            np.testing.assert_allclose(got, mean, atol=1e-3)
    with pytest.raises(InvalidParameterError, match=r"\.tif"):
        export_cog(store, tmp_path / "x.png")


def test_terrain_rgb_parallel_equals_serial_and_whole_map(world, client, tmp_path):
    serial = export_terrain_rgb(world, tmp_path / "s", lonlat=LONLAT)
    parallel = export_terrain_rgb(world, tmp_path / "p", lonlat=LONLAT, client=client)
    assert [p.relative_to(tmp_path / "s") for p in serial] == \
        [p.relative_to(tmp_path / "p") for p in parallel]
    assert _files(tmp_path / "s") == _files(tmp_path / "p")
    # The exporter of the map loaded whole: the same tiles, the finest zooms byte for byte
    # (read from level 0), coarser ones (read from the pyramid) close in height.
    h = _heights(world)
    get_destination("terrain_rgb").export(Heightmap(h, (2.0, 2.0)), tmp_path / "whole",
                                          ExportOptions(name="w", lonlat=LONLAT))
    ours = {k: v for k, v in _files(tmp_path / "p").items() if k.endswith(".png")}
    theirs = {k: v for k, v in _files(tmp_path / "whole").items() if k.endswith(".png")}
    assert ours.keys() == theirs.keys()
    zooms = sorted({int(k.split("/")[0]) for k in ours})
    top = zooms[-1]
    finest = [k for k in ours if int(k.split("/")[0]) >= top - 1]
    assert finest and all(ours[k] == theirs[k] for k in finest)
    relief = float(h.max() - h.min())
    coarse_diffs = []
    for k in ours:
        z = int(k.split("/")[0])
        if z >= top - 1 or z < top - 5:
            continue
        a, ia = _decode_mapbox(tmp_path / "p" / k)
        b, ib = _decode_mapbox(tmp_path / "whole" / k)
        assert np.array_equal(ia, ib)
        if ia.sum() < 16:
            continue
        if z >= top - 3:  # pyramid levels 1-2: close to the full-resolution samples
            coarse_diffs.append(np.abs(a - b)[ia].mean())
        else:  # coarser: point samples of another grid, the same terrain
            assert np.corrcoef(a[ia], b[ia])[0, 1] > 0.9
    assert coarse_diffs and max(coarse_diffs) < 0.05 * relief, coarse_diffs
    # The finest tiles decode to the world's heights (within Terrain-RGB's 0.1 m steps).
    a, inside = _decode_mapbox(tmp_path / "p" / finest[0])
    assert inside.any() and h.min() - 0.1 <= a[inside].min() and a[inside].max() <= h.max() + 0.1


def test_quantized_mesh_parallel_equals_serial_and_the_whole_map_export(world, client,
                                                                        tmp_path):
    import gzip
    import io
    import json

    from quantized_mesh_tile.terrain import TerrainTile

    from terrascape.export._geo import geo_grid, tms_geographic_bounds

    serial = export_quantized_mesh(world, tmp_path / "s", lonlat=LONLAT, name="w")
    parallel = export_quantized_mesh(world, tmp_path / "p", lonlat=LONLAT, name="w",
                                     client=client)
    assert [p.relative_to(tmp_path / "s") for p in serial] == \
        [p.relative_to(tmp_path / "p") for p in parallel]
    ours = _files(tmp_path / "p")
    assert ours == _files(tmp_path / "s")
    # The exporter of the map loaded whole: the same tiles, layer.json and import note; the
    # finest two levels (read from level 0) byte for byte.
    h = _heights(world)
    hm = Heightmap(h, (2.0, 2.0))
    get_destination("cesium").export(hm, tmp_path / "whole",
                                     ExportOptions(name="w", lonlat=LONLAT, workers=1))
    theirs = _files(tmp_path / "whole")
    assert ours.keys() == theirs.keys()
    assert ours["layer.json"] == theirs["layer.json"]
    top = json.loads(ours["layer.json"])["maxzoom"]
    tiles = [k for k in ours if k.endswith(".terrain")]
    finest = [k for k in tiles if int(k.split("/")[0]) >= top - 1]
    assert len(finest) > 20 and all(ours[k] == theirs[k] for k in finest)
    # Every tile decodes (quantized-mesh-tile's reader) to heights of the same terrain: the
    # whole map's bilinear samples at the vertices, within the level's pyramid smoothing.
    grid = geo_grid(hm, LONLAT)
    relief = float(h.max() - h.min())
    diffs = {}
    for k in tiles:
        z, x, y = (int(v) for v in k.removesuffix(".terrain").split("/"))
        w, s, e, n = tms_geographic_bounds(z, x, y)
        tile = TerrainTile(west=w, south=s, east=e, north=n)
        tile.fromBytesIO(io.BytesIO(gzip.decompress(ours[k])), hasLighting=True,
                         hasWatermask=True)
        lon, lat, got = np.asarray(tile.getVerticesCoordinates()).T
        want, inside = grid.sample(lon, lat)
        if inside.sum() < 8:
            continue
        assert h.min() - 0.01 * relief <= got[inside].min() <= got[inside].max() \
            <= h.max() + 0.01 * relief
        diffs.setdefault(z, []).append(float(np.abs(got - want)[inside].mean()))
    for z in range(top - 1, top + 1):  # level 0: within the level error and 15-bit step
        assert max(diffs[z]) <= 1.0 * 2 ** (top - z) + relief / 32767, (z, diffs[z])
    for z in range(top - 5, top - 1):
        assert max(diffs[z]) < 0.05 * relief, (z, diffs[z])


def test_cli_world_export(world, tmp_path):
    import rasterio
    from typer.testing import CliRunner

    from terrascape.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["world", "export", str(world), str(tmp_path / "w.tif"),
                              "--workers", "2", "--threads"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "w.tif") as src:
        assert np.array_equal(src.read(1), _heights(world))
        assert src.tags(ns="IMAGE_STRUCTURE").get("LAYOUT") != "COG"
    res = runner.invoke(app, ["world", "export", str(world), str(tmp_path / "cog.tif"),
                              "--format", "cog", "--threads"])
    assert res.exit_code == 0, res.output
    with rasterio.open(tmp_path / "cog.tif") as src:
        assert src.tags(ns="IMAGE_STRUCTURE")["LAYOUT"] == "COG"
        assert np.array_equal(src.read(1), _heights(world))
    res = runner.invoke(app, ["world", "export", str(world), str(tmp_path / "qm"),
                              "--format", "quantized-mesh", "--lonlat", "15,45", "--min-zoom",
                              "17", "--threads"])
    assert res.exit_code == 0, res.output
    whole = tmp_path / "whole"
    get_destination("cesium").export(Heightmap(_heights(world), (2.0, 2.0)), whole,
                                     ExportOptions(name=world.stem, lonlat=LONLAT, min_zoom=17,
                                                   workers=1))
    assert _files(tmp_path / "qm") == _files(whole)
    res = runner.invoke(app, ["world", "export", str(world), str(tmp_path / "tiles"),
                              "--format", "terrarium", "--lonlat", "15,45", "--min-zoom", "15",
                              "--threads"])
    assert res.exit_code == 0, res.output
    tiles = sorted((tmp_path / "tiles").rglob("*.png"))
    assert tiles and (tmp_path / "tiles" / "tiles.json").exists()
    a = np.asarray(Image.open(tiles[0])).astype(np.float64)
    dec = a[..., 0] * 256 + a[..., 1] + a[..., 2] / 256 - 32768
    inside = a[..., 3] > 0
    h = _heights(world)
    assert inside.any() and h.min() - 0.01 <= dec[inside].min() <= dec[inside].max() \
        <= h.max() + 0.01


def test_export_errors(world, tmp_path, capsys):
    from terrascape.cli.app import run_app

    assert run_app(["world", "export", str(world), str(tmp_path / "t"), "--format",
                    "mapbox"]) == 2
    assert "--lonlat" in capsys.readouterr().err
    assert run_app(["world", "export", str(world), str(tmp_path / "x.png")]) == 2
    assert ".tif" in capsys.readouterr().err
    assert run_app(["world", "export", str(world), str(tmp_path / "x.tif"), "--format",
                    "webp"]) == 2
    with pytest.raises(InvalidParameterError, match="longitude"):
        export_terrain_rgb(world, tmp_path / "t", lonlat=(200.0, 0.0))
    assert run_app(["world", "export", str(world), str(tmp_path / "q"), "--format",
                    "quantized-mesh"]) == 2
    assert "--lonlat" in capsys.readouterr().err
    with pytest.raises(InvalidParameterError, match="max-error"):
        export_quantized_mesh(world, tmp_path / "q", lonlat=LONLAT, max_error=-1.0)
    with pytest.raises(InvalidParameterError, match="longitude"):
        export_quantized_mesh(world, tmp_path / "q", lonlat=(0.0, 89.0))
    with pytest.raises(InvalidParameterError, match="min-zoom"):
        export_quantized_mesh(world, tmp_path / "q", lonlat=LONLAT, min_zoom=9, max_zoom=8)
    assert not (tmp_path / "q").exists() or not any((tmp_path / "q").rglob("*.terrain"))


def test_export_command_takes_a_world(world, tmp_path):
    from typer.testing import CliRunner

    from terrascape.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["export", "terrain_rgb", str(world), "-o", str(tmp_path / "t"),
                              "--lonlat", "15,45", "--min-zoom", "16"])
    assert res.exit_code == 0, res.output
    ours = _files(tmp_path / "t")
    export_terrain_rgb(world, tmp_path / "s", lonlat=LONLAT, min_zoom=16, name="w")
    assert ours == _files(tmp_path / "s") and any(k.endswith(".png") for k in ours)
    res = runner.invoke(app, ["export", "cesium", str(world), "-o", str(tmp_path / "c"),
                              "--lonlat", "15,45", "--min-zoom", "17"])
    assert res.exit_code == 0, res.output
    export_quantized_mesh(world, tmp_path / "q", lonlat=LONLAT, min_zoom=17, name="w")
    assert _files(tmp_path / "c") == _files(tmp_path / "q")
    res = runner.invoke(app, ["export", "unity", str(world), "-o", str(tmp_path / "u")])
    assert res.exit_code != 0


def test_quantized_mesh_of_a_world_takes_the_static_mesher(world, tmp_path):
    """``--mesher greedy`` for a world: the finest tiles byte for byte those of the map
    loaded whole with the same mesher, fewer triangles than RTIN's, and the command's
    tiles the same."""
    from typer.testing import CliRunner

    from terrascape.cli import app

    greedy = export_quantized_mesh(world, tmp_path / "g", lonlat=LONLAT, min_zoom=17,
                                   name="w", mesher="greedy")
    export_quantized_mesh(world, tmp_path / "r", lonlat=LONLAT, min_zoom=17, name="w")
    whole = tmp_path / "whole"
    get_destination("cesium").export(Heightmap(_heights(world), (2.0, 2.0)), whole,
                                     ExportOptions(name="w", lonlat=LONLAT, workers=1,
                                                   min_zoom=17, mesher="greedy"))
    ours, rtin = _files(tmp_path / "g"), _files(tmp_path / "r")
    assert ours == _files(whole)
    assert len(greedy) == len([k for k in ours if not k.startswith(".")])  # not the manifest
    tiles = [k for k in ours if k.endswith(".terrain")]
    assert tiles and ours.keys() == rtin.keys()
    assert sum(len(ours[k]) for k in tiles) < sum(len(rtin[k]) for k in tiles)
    res = CliRunner().invoke(app, ["export", "cesium", str(world), "-o", str(tmp_path / "c"),
                                   "--lonlat", "15,45", "--min-zoom", "17", "--mesher",
                                   "greedy"])
    assert res.exit_code == 0, res.output
    assert _files(tmp_path / "c") == ours
    with pytest.raises(InvalidParameterError, match="unknown static mesher"):
        export_quantized_mesh(world, tmp_path / "b", lonlat=LONLAT, mesher="bogus")
    assert not (tmp_path / "b").exists()


def test_a_world_at_spacing_one_exports_without_gdals_warning(tmp_path):
    # the transform of spacing 1 is one rasterio warns "may be ignored"; it is kept, so the
    # user must not be told otherwise
    import warnings

    import rasterio

    recipe = recipe_from_dict({"size": [70, 90], "seed": 3, "chunk": 64,
                               "generator": {"name": "fbm", "relief": 20.0, "scale": 30.0}})
    store = tmp_path / "w.zarr"
    assert build_world(recipe, store).complete
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        export_geotiff(store, tmp_path / "g.tif")
        export_cog(store, tmp_path / "c.tif", blocksize=64)
    for name in ("g.tif", "c.tif"):
        with rasterio.open(tmp_path / name) as src:
            assert src.transform == rasterio.Affine(1, 0, 0, 0, -1, 0) and src.crs is None
            assert np.array_equal(src.read(1), _heights(store))


@pytest.mark.parametrize("kind", ["quantized-mesh", "terrain_rgb"])
@pytest.mark.parametrize("on_cluster", [False, True])
def test_an_interrupted_world_export_leaves_nothing_and_keeps_the_earlier_one(
        world, client, tmp_path, monkeypatch, kind, on_cluster):
    """The tiles of a world's pyramid appear all together or not at all: a failure in a
    tile of the second batch (a full disk here; a signal takes the same way out) leaves no
    tile of the batch finished before it, in a new folder, and over an earlier export
    (``force``) leaves the earlier files as they were."""
    import errno

    import terrascape.world.export as world_export

    def export(out, **kw):
        if kind == "quantized-mesh":
            return export_quantized_mesh(world, out, lonlat=LONLAT, min_zoom=14, name="w",
                                         client=client if on_cluster else None, **kw)
        return export_terrain_rgb(world, out, lonlat=LONLAT, name="w",
                                  client=client if on_cluster else None, **kw)

    earlier = export(tmp_path / "old")
    fail_at = (world_export.QM_TILES_PER_TASK if kind == "quantized-mesh"
               else world_export.RGB_TILES_PER_TASK) + 2
    assert len(earlier) > fail_at + 1
    before = _files(tmp_path / "old")
    name = "_quantized_mesh_tile" if kind == "quantized-mesh" else "_rgb_tile"
    make = getattr(world_export, name)
    calls = [0]

    def failing(*args, **kwargs):
        calls[0] += 1
        if calls[0] == fail_at:
            raise OSError(errno.ENOSPC, "No space left on device")
        return make(*args, **kwargs)

    monkeypatch.setattr(world_export, name, failing)
    for out, force in ((tmp_path / "new", False), (tmp_path / "old", True)):
        calls[0] = 0
        with pytest.raises(OSError, match="No space"):
            export(out, force=force)
        assert calls[0] >= fail_at
        if force:
            assert _files(out) == before
            assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == \
                sorted(p.name for p in (tmp_path / "old").iterdir() if p.name.startswith("."))
        else:
            assert not out.exists() or not any(out.rglob("*")), sorted(out.rglob("*"))[:5]


def test_a_signal_during_a_world_export_leaves_no_folder_and_after_it_counts_the_tiles(
        world, tmp_path, monkeypatch, capsys):
    """Interrupted while the tiles are made, ``world export`` leaves neither a tile nor the
    folder it made; interrupted once they were committed, it says how many files it kept
    and where, in one line, not thousands of names."""
    import signal

    import terrascape.export._common
    import terrascape.world.export as world_export
    from terrascape.cli.app import run_app
    from terrascape.errors import Interrupted

    def interrupted(*args, **kwargs):
        raise Interrupted(signal.SIGTERM)

    command = ["world", "export", str(world), "", "--format", "quantized-mesh", "--lonlat",
               "15,45", "--min-zoom", "14", "--threads"]
    command[3] = str(tmp_path / "during")
    run = world_export._run

    def tiles_made_then_interrupted(*args):
        run(*args)  # every tile is made and staged: the signal comes before their commit
        interrupted()

    with monkeypatch.context() as m:
        m.setattr(world_export, "_run", tiles_made_then_interrupted)
        assert run_app(command) == 143
    assert "nothing was written" in capsys.readouterr().err
    assert not (tmp_path / "during").exists()
    command[3] = str(tmp_path / "after")
    # after the unit's commit, before the command returns
    monkeypatch.setattr(terrascape.export._common, "_remove_empty_folders", interrupted)
    assert run_app(command) == 143
    err = capsys.readouterr().err
    tiles = sorted((tmp_path / "after").rglob("*.terrain"))
    assert len(tiles) > 100 and (tmp_path / "after" / "layer.json").exists()
    assert f"kept: {len(tiles) + 3:,} files in {tmp_path / 'after'}" in err, err
    assert len(err.splitlines()) == 1


def test_a_world_export_failing_after_its_tiles_are_placed_takes_them_back(world, tmp_path,
                                                                          monkeypatch):
    """The tiles are named before the metadata's commit: when that commit fails (a full
    disk), the new tiles go and the earlier export's come back, byte for byte."""
    import errno

    import terrascape.io.atomic as atomic

    export_quantized_mesh(world, tmp_path / "old", lonlat=LONLAT, min_zoom=15, name="w")
    before = _files(tmp_path / "old")
    commit = atomic._commit

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(atomic, "_commit", full_disk)
    for out, kw in ((tmp_path / "new", {}), (tmp_path / "old", {"force": True}),
                    (tmp_path / "old", {"force": True, "min_zoom": 16})):
        args = {"lonlat": LONLAT, "min_zoom": 14, "name": "w", **kw}
        with pytest.raises(Exception, match="No space"):
            export_quantized_mesh(world, out, **args)
        if out.name == "old":
            assert _files(out) == before
        else:
            assert not out.exists() or not any(out.rglob("*"))
    monkeypatch.setattr(atomic, "_commit", commit)
    again = export_quantized_mesh(world, tmp_path / "old", lonlat=LONLAT, min_zoom=14,
                                  name="w", force=True)
    assert len(again) > len([k for k in before if k.endswith(".terrain")])


def test_a_task_run_again_rewrites_its_staged_tiles_and_a_late_one_writes_nothing(tmp_path):
    """dask runs a task again when its worker died: the tiles the first run staged are
    written over, not refused. A task that runs after the command removed its staging
    folder (interrupted) fails without making the folder again."""
    from terrascape.world.export import _stage

    folder = tmp_path / ".tiles-x.part"
    folder.mkdir()
    _stage(str(folder), [("3-4-5.terrain", b"first")])
    _stage(str(folder), [("3-4-5.terrain", b"again")])
    assert (folder / "3-4-5.terrain").read_bytes() == b"again"
    folder.joinpath("3-4-5.terrain").unlink()
    folder.rmdir()
    with pytest.raises(FileNotFoundError):
        _stage(str(folder), [("3-4-5.terrain", b"late")])
    assert list(tmp_path.iterdir()) == []


def test_a_world_export_holds_its_folder_while_its_tiles_are_named(world, tmp_path,
                                                                   monkeypatch):
    """From the tiles' naming to the end of the metadata's commit the output folder is
    locked: another export (another process) into it waits instead of mixing its tiles
    in."""
    import subprocess
    import sys

    import terrascape.io.atomic as atomic

    place = atomic.place_files
    seen = []
    probe = ("import fcntl, os, sys; fd = os.open(sys.argv[1], os.O_RDONLY)\n"
             "try:\n    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB); print('free')\n"
             "except BlockingIOError:\n    print('held')")

    def probing(*args, **kwargs):
        seen.append(subprocess.run([sys.executable, "-c", probe, str(tmp_path / "q")],
                                   capture_output=True, text=True, timeout=60).stdout.strip())
        return place(*args, **kwargs)

    monkeypatch.setattr(atomic, "place_files", probing)
    export_quantized_mesh(world, tmp_path / "q", lonlat=LONLAT, min_zoom=17, name="w")
    assert seen == ["held"]
    done = subprocess.run([sys.executable, "-c", probe, str(tmp_path / "q")],
                          capture_output=True, text=True, timeout=60).stdout.strip()
    assert done == "free"
