"""``terrascape erode``: erosion of a heightmap file, optionally with float32 masks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from terrascape._validate import check_int
from terrascape.cli.app import MAX_MEMORY, app, out, timed, use_max_memory
from terrascape.cli.cmd_generate import _FORCE, _QUIET, _SEED, _check_outputs, _finish
from terrascape.errors import InvalidParameterError
from terrascape.filters import MASK_NAMES, MODELS, erode, hydraulic_erosion, thermal_erosion
from terrascape.filters.erosion_models import DEFAULT_DEPOSITION
from terrascape.io import atomic_output, check_output_path, output_unit, read_heightmap
from terrascape.memory import check_grid


def _read_map(path: Path, name: str, shape: tuple[int, int]):
    """A per-sample parameter map from any heightmap file, checked against the input."""
    parameter_map = read_heightmap(path)
    if parameter_map.metadata.get("filled"):
        # Heights may have holes filled; a rain or talus map with holes is a mistake.
        raise InvalidParameterError(
            f"{name} {path.name} has {parameter_map.metadata['filled']} NaN/infinite sample(s); "
            "a parameter map needs a finite value everywhere")
    values = parameter_map.heights
    if values.shape != shape:
        raise InvalidParameterError(
            f"{name} {path.name} is {values.shape[1]}×{values.shape[0]}, the heightmap is "
            f"{shape[1]}×{shape[0]}")
    return np.asarray(values, dtype=np.float64)


@app.command("erode")
def erode_cmd(
    input_path: Path = typer.Argument(..., metavar="IN", help="Input heightmap file."),
    output: Path = typer.Argument(..., metavar="OUT", help="Output heightmap file."),
    model: str = typer.Option(
        None, "--model",
        help="stream-power (default: valleys and river networks that drain like real "
             "terrain), grid (virtual-pipe water), droplets, or thermal (talus).",
        show_default="stream-power"),
    iterations: int = typer.Option(
        None, "--iterations", "-n",
        help="Model steps (droplets: number of droplets).",
        show_default="stream-power 20, grid 300, droplets 1 per sample, thermal 50"),
    strength: float = typer.Option(
        1.0, "--strength", help="Erosion rate relative to the model's default."),
    deposition: float = typer.Option(
        None, "--deposition",
        help="Stream-power: how much of the river load settles where the slope eases "
             "(0 = erode only; larger builds bigger fans), 0 to 10.",
        show_default="1"),
    masks: Path = typer.Option(
        None, "--masks",
        help="Folder for float32 .npy masks: flow, deposition, wear, water.",
        show_default="none"),
    rain: float = typer.Option(
        None, "--rain", help="Grid model: rain per second (world units).",
        show_default="0.01"),
    dt: float = typer.Option(
        None, "--dt", help="Grid model: time step in seconds (at most the stable limit).",
        show_default="half the stable limit"),
    evaporation: float = typer.Option(
        None, "--evaporation", help="Grid model: evaporation per second.",
        show_default="0.01"),
    rain_map: Path = typer.Option(
        None, "--rain-map", help="Grid model: rain per sample from a heightmap file.",
        show_default="uniform"),
    talus_map: Path = typer.Option(
        None, "--talus-map",
        help="Thermal model: talus angle in degrees per sample from a heightmap file.",
        show_default="--talus everywhere"),
    thermal: int = typer.Option(
        0, "--thermal", help="Thermal iterations after the model (0 = off)."),
    talus: float = typer.Option(30.0, "--talus", help="Talus angle for thermal erosion (deg)."),
    hydraulic: int = typer.Option(
        0, "--hydraulic",
        help="Droplets before thermal (0 = off); without --model, these two alone run."),
    seed: int = _SEED,
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Erode a heightmap. With no options: stream-power river erosion (drained valleys)."""
    thermal = check_int(thermal, "--thermal", minimum=0)
    hydraulic = check_int(hydraulic, "--hydraulic", minimum=0)
    if iterations is not None:
        check_int(iterations, "--iterations", minimum=0)
    if model is not None and model not in MODELS:
        raise InvalidParameterError(f"--model must be one of {', '.join(MODELS)}, got {model!r}")
    legacy = model is None and (thermal > 0 or hydraulic > 0)
    if deposition is not None and (legacy or (model or "stream-power") != "stream-power"):
        raise InvalidParameterError("--deposition applies to the stream-power model only")
    _check_outputs(output, None, force)
    mask_paths: dict[str, Path] = {}
    if masks is not None:
        if legacy:
            raise InvalidParameterError("--masks needs a --model (or no --thermal/--hydraulic)")
        if not masks.is_dir():
            raise InvalidParameterError(f"--masks folder {masks} does not exist")
        mask_paths = {name: masks / f"{name}.npy" for name in MASK_NAMES}
        for path in mask_paths.values():
            check_output_path(path, force=force)
    with timed("read", quiet=quiet):
        hm = read_heightmap(input_path)
    use_max_memory(max_memory)
    check_grid("erode", hm.rows, hm.cols, hint="erode a smaller map (or raise --max-memory)")
    original = hm.heights
    if rain_map is not None:
        if rain is not None:
            raise InvalidParameterError("give --rain or --rain-map, not both")
        rain = _read_map(rain_map, "--rain-map", hm.shape)
    talus_angle = (_read_map(talus_map, "--talus-map", hm.shape) if talus_map is not None
                   else talus)
    result_masks = {}
    if legacy:
        if hydraulic:
            with timed("hydraulic erosion", quiet=quiet):
                hm = hydraulic_erosion(hm, droplets=hydraulic, seed=seed)
    else:
        name = model or "stream-power"
        with timed(f"{name} erosion", quiet=quiet):
            result = erode(hm, model=name, iterations=iterations, strength=strength, seed=seed,
                           talus_angle=talus_angle, rain=rain, dt=dt, evaporation=evaporation,
                           deposition=DEFAULT_DEPOSITION if deposition is None else deposition)
        hm, result_masks = result.heightmap, result.masks
    if thermal:
        with timed("thermal erosion", quiet=quiet):
            hm = thermal_erosion(hm, iterations=thermal, talus_angle=talus_angle)
        if result_masks:  # the height changes now include the slumping
            dh = hm.heights.astype(np.float64) - original
            result_masks["deposition"] = np.maximum(dh, 0.0).astype(np.float32)
            result_masks["wear"] = np.maximum(-dh, 0.0).astype(np.float32)

    # The masks and the heightmap are one unit: all appear together, and an error or a
    # signal anywhere, their final renames included, leaves none of them behind.
    with output_unit():
        for name, path in mask_paths.items():
            with atomic_output(path, force=force) as tmp, open(tmp, "wb") as fh:
                np.save(fh, np.ascontiguousarray(result_masks[name], dtype=np.float32))
        _finish(hm, output, None, None, force, quiet)
    if mask_paths:
        out.print(f"masks {', '.join(str(p) for p in mask_paths.values())}")
