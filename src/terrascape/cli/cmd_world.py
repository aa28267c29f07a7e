"""``terrascape world``: build worlds bigger than memory on dask, chunk by chunk, into zarr."""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.cli.app import app, out

world_app = typer.Typer(
    help="Worlds bigger than memory: build a recipe chunk by chunk on a dask cluster into a "
    "resumable zarr store, and describe a store.",
    no_args_is_help=True,
)
app.add_typer(world_app, name="world")


@world_app.command("build")
def world_build_cmd(
    recipe_path: Path = typer.Argument(..., metavar="RECIPE",
                                       help="Recipe file (.toml or .json)."),
    output: Path = typer.Option(..., "--output", "-o", help="World store (world.zarr)."),
    scheduler: str = typer.Option(
        "local", "--scheduler",
        help="local (a new LocalCluster) or the address of a running dask scheduler "
             "(tcp://host:8786)."),
    workers: int = typer.Option(2, "--workers", help="Workers of the local cluster."),
    memory_limit: str = typer.Option("2GB", "--memory-limit",
                                     help="Memory limit per local worker process (dask syntax; "
                                          "none with --threads)."),
    processes: bool = typer.Option(
        True, "--processes/--threads",
        help="Local workers as processes (parallel numba kernels) or threads of this one."),
    force: bool = typer.Option(False, "--force",
                               help="Replace a store built from another recipe."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bars."),
) -> None:
    """Build (or continue) the world of RECIPE: a killed build run again keeps its finished
    chunks and gives the same bytes."""
    from terrascape.world import build_world, load_recipe

    recipe = load_recipe(recipe_path)
    result = build_world(recipe, output, scheduler=scheduler, workers=workers,
                         memory_limit=memory_limit, processes=processes, force=force,
                         quiet=quiet)
    if not quiet:
        samples = recipe.rows * recipe.cols
        out.print(f"{output}: {recipe.cols}×{recipe.rows} ({samples / 1e6:.1f} M samples), "
                  f"{result.written} chunks written, {result.skipped} kept from before, "
                  f"{result.seconds:.1f} s")


@world_app.command("info")
def world_info_cmd(
    store: Path = typer.Argument(..., metavar="WORLD", help="World store (world.zarr)."),
) -> None:
    """Size, chunks, arrays, pyramid levels, completeness and recipe of a world store."""
    from terrascape.world import world_info

    for line in world_info(store).lines():
        out.print(line, markup=False, highlight=False)


@world_app.command("export")
def world_export_cmd(
    store: Path = typer.Argument(..., metavar="WORLD", help="World store (world.zarr)."),
    output: Path = typer.Argument(..., metavar="OUT",
                                  help="A .tif file (geotiff, cog), or a folder for tiles."),
    fmt: str = typer.Option(
        "geotiff", "--format",
        help="geotiff (tiled float32, deflate), cog (Cloud-Optimized GeoTIFF: tiled, with "
             "overviews), mapbox (Terrain-RGB tiles), terrarium or quantized-mesh (the Cesium "
             "terrain pyramid)."),
    lonlat: str = typer.Option(None, "--lonlat",
                               help="Tiles: the world's centre LON,LAT (degrees).",
                               show_default=False),
    min_zoom: int = typer.Option(None, "--min-zoom", min=0, max=24,
                                 help="Tiles: first level.", show_default="0"),
    max_zoom: int = typer.Option(None, "--max-zoom", min=0, max=24, help="Tiles: last level.",
                                 show_default="as dense as the world"),
    max_error: float = typer.Option(
        1.0, "--max-error", help="quantized-mesh: vertical error of the finest level "
        "(metres; doubles per coarser level)."),
    scheduler: str = typer.Option(
        "local", "--scheduler",
        help="local (a new LocalCluster) or the address of a running dask scheduler."),
    workers: int = typer.Option(2, "--workers", help="Workers of the local cluster."),
    processes: bool = typer.Option(
        True, "--processes/--threads",
        help="Local workers as processes or threads of this one."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing files."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No summary line."),
) -> None:
    """Export a world tile by tile on a dask cluster (the same bytes as one process)."""
    import time

    from terrascape.cli.cmd_export import _no_empty_folder
    from terrascape.cli.parsing import parse_floats
    from terrascape.errors import InvalidParameterError
    from terrascape.world import connect, open_world
    from terrascape.world.export import (
        export_cog,
        export_geotiff,
        export_quantized_mesh,
        export_terrain_rgb,
    )

    if fmt not in ("geotiff", "cog", "mapbox", "terrarium", "quantized-mesh"):
        raise InvalidParameterError(
            f"--format must be geotiff, cog, mapbox, terrarium or quantized-mesh, got {fmt!r}")
    open_world(store)  # a clear error before a cluster starts
    if fmt in ("geotiff", "cog"):
        if output.suffix.lower() not in (".tif", ".tiff"):
            raise InvalidParameterError(f"{fmt} output must end in .tif, got {output.name!r}")
        from terrascape.io.atomic import check_output_path

        check_output_path(output, force=force)
    elif lonlat is None:
        raise InvalidParameterError("tiles need --lonlat LON,LAT to place the world on the globe")
    else:
        ll = tuple(parse_floats(lonlat, 2, name="--lonlat"))  # before a cluster starts
    start = time.perf_counter()
    with (_no_empty_folder(output),
          connect(scheduler, workers=workers, memory_limit="2GB", processes=processes) as client):
        if fmt == "geotiff":
            written = [export_geotiff(store, output, client=client, force=force)]
        elif fmt == "cog":
            written = [export_cog(store, output, client=client, force=force)]
        elif fmt == "quantized-mesh":
            written = export_quantized_mesh(store, output, lonlat=ll, min_zoom=min_zoom,
                                            max_zoom=max_zoom, max_error=max_error,
                                            name=store.stem, client=client, force=force)
        else:
            written = export_terrain_rgb(store, output, lonlat=ll, fmt=fmt, min_zoom=min_zoom,
                                         max_zoom=max_zoom, name=store.stem, client=client,
                                         force=force)
    if not quiet:
        total = sum(p.stat().st_size for p in written)
        out.print(f"{output}: {len(written)} files, {total:,} bytes, "
                  f"{time.perf_counter() - start:.1f} s")
