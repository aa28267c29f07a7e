"""``terrascape erode``: thermal and hydraulic erosion of a heightmap file."""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.cli.app import MAX_MEMORY, app, timed, use_max_memory
from terrascape.cli.cmd_generate import _FORCE, _QUIET, _SEED, _check_outputs, _finish
from terrascape.errors import InvalidParameterError


@app.command("erode")
def erode_cmd(
    input_path: Path = typer.Argument(..., metavar="IN", help="Input heightmap file."),
    output: Path = typer.Argument(..., metavar="OUT", help="Output heightmap file."),
    thermal: int = typer.Option(0, "--thermal", help="Thermal-erosion iterations (0 = off)."),
    talus: float = typer.Option(30.0, "--talus", help="Talus angle for thermal erosion (deg)."),
    hydraulic: int = typer.Option(0, "--hydraulic", help="Hydraulic droplets (0 = off)."),
    seed: int = _SEED,
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Erode a heightmap: thermal (talus) and/or droplet hydraulic erosion; mass conserved."""
    from terrascape._validate import check_int
    from terrascape.filters import hydraulic_erosion, thermal_erosion
    from terrascape.io import read_heightmap

    thermal = check_int(thermal, "--thermal", minimum=0)
    hydraulic = check_int(hydraulic, "--hydraulic", minimum=0)
    if thermal == 0 and hydraulic == 0:
        raise InvalidParameterError("give --thermal N and/or --hydraulic N (both are 0)")
    _check_outputs(output, None, force)
    with timed("read", quiet=quiet):
        hm = read_heightmap(input_path)
    from terrascape.memory import check_grid

    use_max_memory(max_memory)
    check_grid("erode", hm.rows, hm.cols, hint="erode a smaller map (or raise --max-memory)")
    if hydraulic:
        with timed("hydraulic erosion", quiet=quiet):
            hm = hydraulic_erosion(hm, droplets=hydraulic, seed=seed)
    if thermal:
        with timed("thermal erosion", quiet=quiet):
            hm = thermal_erosion(hm, iterations=thermal, talus_angle=talus)
    _finish(hm, output, None, None, force, quiet)
