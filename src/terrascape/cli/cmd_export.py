"""``terrascape export DESTINATION HEIGHTMAP -o FOLDER`` — terrain for engines, GIS and the web.

Destinations come from :mod:`terrascape.export` (one module each); every one writes a
``NAME_import.txt`` next to its files with the exact import settings.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Iterator
from pathlib import Path

import typer

from terrascape.cli.app import app, console, max_memory_option, out, timed, use_max_memory
from terrascape.cli.geo_options import NO_REPROJECT, metric_map
from terrascape.cli.parsing import is_world_store
from terrascape.export import destinations
from terrascape.lod.static_meshers import DEFAULT_STATIC_MESHER, STATIC_MESHERS

#: Destinations that tile the globe: they take a map in degrees as it is.
_GLOBE_DESTINATIONS = ("cesium", "terrain_rgb")


@contextlib.contextmanager
def _no_empty_folder(folder: Path) -> Iterator[None]:
    """When the export fails, take away the output folder if this command made it and left
    it empty (its empty sub-folders too; never a file): an error leaves nothing behind."""
    top = None  # the outermost folder of the path that is not there yet
    for path in (folder.absolute(), *folder.absolute().parents):
        if path.exists():
            break
        top = path
    try:
        yield
    except BaseException:
        if top is not None and top.is_dir():
            for root, _, _ in sorted(os.walk(top), key=lambda w: -len(w[0])):
                with contextlib.suppress(OSError):  # only empty folders go
                    os.rmdir(root)
        raise


#: Files in the output's sub-folders listed one by one up to this many; a tile pyramid's
#: thousands are summed up in one line.
_LISTED_TILES = 20


def _print_written(written: list[Path], output: Path) -> None:
    """One line per file of the output folder itself, then those of its sub-folders (a
    pyramid's tiles) one by one when they are few, or as one line of count and size."""
    top = [path for path in written if path.parent == output]
    below = [path for path in written if path.parent != output]
    shown = top + below if len(below) <= _LISTED_TILES else top
    for path in shown:
        out.print(f"{path} ({path.stat().st_size:,} bytes)", markup=False)
    if len(below) > _LISTED_TILES:
        size = sum(path.stat().st_size for path in below)
        levels = sorted({path.relative_to(output).parts[0] for path in below},
                        key=lambda level: (len(level), level))
        out.print(f"{output / levels[0]} … {output / levels[-1]}: {len(below):,} files "
                  f"({size:,} bytes)", markup=False)


def _destinations_help() -> str:
    from terrascape.export import get_destination

    return "; ".join(get_destination(n).SUMMARY.rstrip(".") for n in destinations()) + "."


def _export_world(destination, store, output, name, lonlat, min_zoom, max_zoom, fmt, force,
                  quiet, max_error=None, mesher=None) -> None:
    """A world store: tiles made in parallel on a local dask cluster, read window by window
    (:mod:`terrascape.world.export`)."""
    from terrascape.cli.parsing import parse_floats
    from terrascape.errors import InvalidParameterError
    from terrascape.world import connect
    from terrascape.world.export import export_quantized_mesh, export_terrain_rgb

    if destination not in ("terrain_rgb", "cesium"):
        raise InvalidParameterError(
            f"a world store exports as terrain_rgb or cesium here (or `terrascape world "
            f"export` for a GeoTIFF), not {destination}")
    if lonlat is None:
        raise InvalidParameterError("a world has no georeference: give --lonlat LON,LAT")
    ll = tuple(parse_floats(lonlat, 2, name="--lonlat"))
    if destination == "cesium":
        with timed("export cesium (world, 2 workers)", quiet=quiet), \
                connect("local", workers=2) as client:
            written = export_quantized_mesh(
                store, output, lonlat=ll, min_zoom=min_zoom, max_zoom=max_zoom,
                max_error=1.0 if max_error is None else max_error, name=name or store.stem,
                client=client, force=force, mesher=mesher)
        out.print(f"{output}: {len(written)} files")
        return
    with timed("export terrain_rgb (world, 2 workers)", quiet=quiet), \
            connect("local", workers=2) as client:
        written = export_terrain_rgb(store, output, lonlat=ll, fmt=fmt or "mapbox",
                                     min_zoom=min_zoom, max_zoom=max_zoom,
                                     name=name or store.stem, client=client, force=force)
    out.print(f"{output}: {len(written)} files")


@app.command("export", help="Export a heightmap for a game engine, GIS or the web. "
             f"Destinations — {_destinations_help()}")
def export_command(
    destination: str = typer.Argument(..., help=f"One of: {', '.join(destinations())}."),
    heightmap: Path = typer.Argument(..., help="Heightmap file (any format `info` reads)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output folder (created if missing)."),
    name: str = typer.Option(None, "--name", help="Base name of the files written.",
                             show_default="the heightmap's file name"),
    fit: str = typer.Option(
        None, "--fit", help="When the size is not one the destination accepts: pad (repeat "
        "edges to the next size), resample (cubic, nearest size, same extent) or crop.",
        show_default="error listing the accepted sizes"),
    tiles: int = typer.Option(1, "--tiles", help="Tiles per side (unity, unreal).", min=1,
                              max=64),
    flip: bool = typer.Option(False, "--flip", help="unity: rows in image order (north "
                              "first), for Unity's Flip Vertically."),
    fmt: str = typer.Option(None, "--format", help="unreal: png|r16; godot: exr|exr16|r16; "
                            "blender: tiff|glb.", show_default="png / exr / tiff"),
    plugin: str = typer.Option(None, "--plugin", help="godot: hterrain|terrain3d.",
                               show_default="hterrain"),
    layers: bool = typer.Option(True, "--layers/--no-layers",
                                help="Also write texture-layer weights (unity, unreal)."),
    lonlat: str = typer.Option(None, "--lonlat", help="cesium, terrain_rgb: place the map's "
                               "centre at LON,LAT (degrees).", show_default="from the CRS"),
    min_zoom: int = typer.Option(None, "--min-zoom", min=0, max=24,
                                 help="Tile pyramids: first level.", show_default="0"),
    max_zoom: int = typer.Option(None, "--max-zoom", min=0, max=24,
                                 help="Tile pyramids: last level.",
                                 show_default="as dense as the map"),
    max_error: float = typer.Option(None, "--max-error", help="blender glb, web: mesh error; "
                                    "cesium: error floor per level (world units).",
                                    show_default="blender 0.5, web relief/500, cesium 1"),
    mesher: str = typer.Option(
        None, "--mesher", help="blender glb, web, cesium: the static mesher — " + "; ".join(
            f"{n} ({m.help})" for n, m in STATIC_MESHERS.items()) + ".",
        show_default=DEFAULT_STATIC_MESHER),
    spacing: str = typer.Option(None, "--spacing", help="Sample spacing DX or DX,DZ in world "
                                "units (overrides the file).", show_default="from file"),
    objects: str = typer.Option(
        None, "--objects", help="Trees, rocks and buildings to export with the terrain: "
        "'default' (the built-in ones by the built-in rules), your own .glb/.gltf model "
        "(scattered like trees) or a .toml/.json rules file. glb and web: in the glb, drawn "
        "instanced; unity, unreal, godot, blender: NAME_objects.glb with the meshes and an "
        "instance list in the engine's axes.", show_default="no objects"),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the objects' placement: the "
                             "same seed puts every object in the same place."),
    sea_level: float = typer.Option(
        None, "--sea-level", help="No objects on ground below this height (world units).",
        show_default="glb and web: the shore of the baked texture's water; else none"),
    compress: str = typer.Option(
        None, "--compress", help="blender glb: quantize (KHR_mesh_quantization: 16-bit "
        "positions, 8-bit normals; Blender 2.91+ imports it, about half the bytes) or none.",
        show_default="none"),
    no_reproject: bool = NO_REPROJECT,
    force: bool = typer.Option(False, "--force", help="Overwrite existing files."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines."),
    max_memory: str = max_memory_option(
        "web, blender glb: refuse the mesh as soon as it is built, before anything is "
        "written,"),
) -> None:
    """Write the destination's files and a NAME_import.txt with the import settings."""
    from terrascape.cli.cmd_files import _parse_spacing
    from terrascape.export import ExportOptions, get_destination
    from terrascape.io import read_heightmap
    from terrascape.io.geotiff import degree_warning

    module = get_destination(destination)
    use_max_memory(max_memory)
    if mesher is not None:
        from terrascape.errors import InvalidParameterError
        from terrascape.lod.static_meshers import static_mesher

        static_mesher(mesher)  # an unknown name: one line naming the choices
        if not getattr(module, "TAKES_MESHER", False):
            raise InvalidParameterError(
                "--mesher goes with " + ", ".join(
                    n for n in destinations() if getattr(get_destination(n), "TAKES_MESHER",
                                                         False))
                + f"; {destination} does not mesh the terrain with it")
    if is_world_store(heightmap):
        with _no_empty_folder(output):
            _export_world(destination, heightmap, output, name, lonlat, min_zoom, max_zoom,
                          fmt, force, quiet, max_error, mesher)
        return
    with timed("read", quiet=quiet), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hm = read_heightmap(heightmap, spacing=_parse_spacing(spacing))
    for w in caught:
        console.print(f"[yellow]warning:[/] {w.message}")
    if destination in _GLOBE_DESTINATIONS:
        # Tile pyramids place the map on the globe from its own CRS (degrees included).
        message = degree_warning(hm)
        if message is not None:
            console.print(f"[yellow]warning:[/] {message}")
    else:
        hm = metric_map(hm, no_reproject=no_reproject)
    from terrascape.cli.parsing import parse_floats

    ll = None if lonlat is None else tuple(parse_floats(lonlat, 2, name="--lonlat"))
    placed = None
    if objects is not None:
        from terrascape.errors import InvalidParameterError
        from terrascape.export.instances import OBJECT_DESTINATIONS

        if destination not in OBJECT_DESTINATIONS:
            raise InvalidParameterError(
                f"--objects goes with {', '.join(OBJECT_DESTINATIONS)}; {destination} tiles "
                "carry the terrain only")
        from terrascape.objects.load import load_objects

        textured = destination == "web" or (destination == "blender" and fmt == "glb")

        def placed(fitted):  # on the map as the destination fits it (pad, resample, crop)
            from terrascape.export.instances import texture_shore

            sea = sea_level
            if sea is None and textured:  # no trees standing in the texture's lakes
                sea = texture_shore(fitted)
            with timed("objects", quiet=quiet):
                return load_objects(objects, fitted, seed=seed, sea_level=sea)

    options = ExportOptions(name=name or heightmap.stem, fit=fit, tiles=tiles, flip=flip,
                            format=fmt, plugin=plugin, layers=layers, force=force, lonlat=ll,
                            min_zoom=min_zoom, max_zoom=max_zoom, max_error=max_error,
                            mesher=mesher, objects=placed, compress=compress)
    compiles = None if mesher is None else STATIC_MESHERS[mesher].first_run_note
    with timed(f"export {destination}", quiet=quiet, slow_note=compiles), \
            _no_empty_folder(output):
        written = module.export(hm, output, options)
    _print_written(written, output)
    removed = getattr(written, "removed", [])
    if removed:
        shown = ", ".join(str(path) for path in removed[:3]) + (", …" if len(removed) > 3 else "")
        out.print(f"removed {len(removed):,} files of the previous {destination} export named "
                  f"{options.name} that this one no longer writes: {shown}", markup=False)
