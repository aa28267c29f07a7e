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
                                     help="Memory limit per local worker (dask syntax)."),
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
