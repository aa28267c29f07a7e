"""Godot 4 terrain: real heights in a one-channel EXR (half or float) or r16, for the HTerrain
(Zylann) and Terrain3D plugins.

HTerrain's importer takes a heightmap of ``2**n + 1`` samples (65 … 4097) as EXR (real
heights) or ``.raw``/``.r16`` (16-bit codes with a min/max height in the dialog). Terrain3D
imports EXR/R16 of any size (its regions are 64 … 2048 samples). The EXR holds the heights in
world units; no scale is needed. ``--format exr16`` writes half floats (within half an ulp).
"""

from __future__ import annotations

from pathlib import Path

from terrascape.errors import InvalidParameterError
from terrascape.export._common import (
    ExportOptions,
    check_name,
    check_out_dir,
    fit_to_sizes,
    one_unit,
    uint16_codes,
    write_bytes,
    write_text,
)
from terrascape.export.instances import write_engine_instances
from terrascape.heightmap import Heightmap
from terrascape.io.exr import write_exr

NAME = "godot"
SUMMARY = "Godot HTerrain / Terrain3D: one-channel EXR (float or half) with real heights, or r16."
HTERRAIN_SIZES = (65, 129, 257, 513, 1025, 2049, 4097)
FORMATS = ("exr", "exr16", "r16")
PLUGINS = ("hterrain", "terrain3d")


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    name = check_name(options.name)
    fmt = options.format or "exr"
    plugin = options.plugin or "hterrain"
    if fmt not in FORMATS:
        raise InvalidParameterError(f"godot --format must be one of {', '.join(FORMATS)}, "
                                    f"got {fmt!r}")
    if plugin not in PLUGINS:
        raise InvalidParameterError(f"godot --plugin must be hterrain or terrain3d, got {plugin!r}")
    if options.tiles != 1:
        raise InvalidParameterError("godot takes one heightmap (its plugins tile internally)")
    hm = heightmap
    if plugin == "hterrain":
        hm = fit_to_sizes(heightmap, HTERRAIN_SIZES, options.fit, square=True,
                          what="Godot HTerrain")
    lo, hi = hm.min, hm.max
    if fmt == "r16":
        path = write_bytes(out / f"{name}.r16",
                           uint16_codes(hm.heights, lo, hi).astype("<u2").tobytes(),
                           force=options.force)
    else:
        path = write_exr(hm, out / f"{name}.exr", force=options.force, half=fmt == "exr16")
    file = path.name
    if plugin == "hterrain":
        lines = [
            f"Godot HTerrain import for {name} (written by terrascape)",
            "",
            "Select the HTerrain node > Terrain > Import",
            f"  Heightmap: {file}",
            f"  Size: {hm.cols} × {hm.rows}",
            (f"  Min Height: {lo:.6g}   Max Height: {hi:.6g}" if fmt == "r16" else
             "  Min/Max Height: not used (the EXR holds real heights)"),
            f"  HTerrain Map Scale: {hm.spacing[0]:.6g} × {hm.spacing[1]:.6g} (node scale x, z)",
        ]
    else:
        lines = [
            f"Godot Terrain3D import for {name} (written by terrascape)",
            "",
            "Terrain3D > Import (Importer tool)",
            f"  height_file_name: {file}   size {hm.cols} × {hm.rows}",
            (f"  r16_range: ({lo:.6g}, {hi:.6g})   r16_size: ({hm.cols}, {hm.rows})"
             if fmt == "r16" else "  import_scale: 1 (the EXR holds real heights)"),
            f"  vertex_spacing: {hm.spacing[0]:.6g}",
        ]
    lines.append(f"Height range: {lo:.6g} … {hi:.6g} world units")
    note = out / f"{name}_import.txt"
    return [path, write_text(note, "\n".join(lines) + "\n", force=options.force),
            *write_engine_instances(NAME, hm, out, name, options)]
