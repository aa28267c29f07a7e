"""``terrascape objects``: place trees, rocks and buildings on a terrain and list them."""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.cli.app import app, out, timed
from terrascape.cli.cmd_generate import _FORCE, _QUIET

objects_app = typer.Typer(
    help="Trees, rocks and buildings on the terrain: place them by rules and list where they "
    "stand, or write the built-in models.",
    no_args_is_help=True,
)
app.add_typer(objects_app, name="objects")

_SPEC_HELP = ("What to place: 'default' (conifers high up, broadleaf trees low and gentle, "
              "bushes, rocks on steep ground, a few houses on flat low ground), your own "
              ".glb/.gltf model (placed like trees) or a .toml/.json rules file.")


@objects_app.command("scatter")
def scatter_cmd(
    input_path: Path = typer.Argument(..., metavar="IN", help="Heightmap file."),
    output: Path = typer.Argument(..., metavar="OUT",
                                  help="Instance list to write (.json): every object's model, "
                                  "position, turn and size, with counts per rule."),
    objects: str = typer.Option("default", "--objects", help=_SPEC_HELP),
    seed: int = typer.Option(0, "--seed", min=0,
                             help="Seed of the placement (same seed → same file)."),
    sea_level: float = typer.Option(
        None, "--sea-level", help="Nothing stands on ground below this height (world units).",
        show_default="none"),
    exaggeration: float = typer.Option(
        1.0, "--exaggeration", help="Vertical scale the terrain is drawn with: the objects' "
        "feet are put on the surface as drawn."),
    masks: Path = typer.Option(
        None, "--masks", help="Folder with the erosion masks of `terrascape erode --masks` "
        "(flow, deposition, wear, water .npy) that rules may read; with 'default', rocks "
        "also gather on worn ground.", show_default="none"),
    max_objects: int = typer.Option(
        None, "--max-objects", min=1, help="The most objects to place: rules asking for more "
        "are an error (the built-in rules thin out instead).", show_default="200,000"),
    spacing: str = typer.Option(None, "--spacing", help="Sample spacing DX or DX,DZ in world "
                                "units (overrides the file).", show_default="from file"),
    force: bool = _FORCE,
    quiet: bool = _QUIET,
) -> None:
    """Place objects on a heightmap by rules and write where each one stands (JSON)."""
    from terrascape.cli.cmd_files import _parse_spacing
    from terrascape.errors import InvalidParameterError
    from terrascape.export.instances import instances_json
    from terrascape.io import atomic_output, check_output_path, read_heightmap
    from terrascape.objects.load import load_objects, read_masks

    if output.suffix.lower() != ".json":
        raise InvalidParameterError(f"the instance list is JSON: give OUT as a .json file, got "
                                    f"{output.name}")
    check_output_path(output, force=force)
    with timed("read", quiet=quiet):
        hm = read_heightmap(input_path, spacing=_parse_spacing(spacing))
        mask_arrays = read_masks(masks) if masks is not None else None
    with timed("scatter", quiet=quiet):
        inst = load_objects(objects, hm, seed=seed, exaggeration=exaggeration,
                            masks=mask_arrays, sea_level=sea_level, max_objects=max_objects)
    text = instances_json(inst, hm)
    with atomic_output(output, force=force) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    if not quiet:
        for rule in inst.metadata.get("rules", []):
            note = "" if rule["placed"] == rule["target"] else f" (of {rule['target']} asked)"
            out.print(f"{rule['name']}: {rule['placed']:,}{note}", markup=False,
                      highlight=False)
        factor = inst.metadata.get("density_factor", 1.0)
        if factor < 1:
            out.print(f"densities thinned to {factor:.3g}× to stay under "
                      f"{inst.metadata['max_objects']:,} objects", markup=False)
    out.print(f"{output}: {len(inst):,} objects", markup=False, highlight=False)


@objects_app.command("meshes")
def meshes_cmd(
    output: Path = typer.Argument(..., metavar="OUT", help="glb file to write."),
    force: bool = _FORCE,
) -> None:
    """Write the built-in models to one glb, one node per model, in metres."""
    from terrascape.errors import InvalidParameterError
    from terrascape.export.instances import objects_glb
    from terrascape.io import atomic_output, check_output_path
    from terrascape.objects import builtin_meshes

    if output.suffix.lower() != ".glb":
        raise InvalidParameterError(f"give OUT as a .glb file, got {output.name}")
    check_output_path(output, force=force)
    meshes = builtin_meshes()
    with atomic_output(output, force=force) as tmp:
        Path(tmp).write_bytes(objects_glb(meshes.values()))
    out.print(f"{output}: {', '.join(meshes)}", markup=False, highlight=False)
