"""Blender: a float32 TIFF displacement map (real heights) or a textured glb.

TIFF: add a Plane of the terrain's extent, subdivide it, add a Displace modifier with an image
texture of the TIFF (Color Space "Non-Color", Extension "Extend"), Strength 1 and Midlevel 0:
the float samples are the heights themselves. glb: File > Import > glTF 2.0 — the mesh is in
metres with the baked colour texture (Blender converts glTF's Y up to its Z up).
"""

from __future__ import annotations

from pathlib import Path

from terrascape.errors import InvalidParameterError
from terrascape.export._common import ExportOptions, check_name, check_out_dir, one_unit, write_text
from terrascape.export.instances import objects_for, write_engine_instances
from terrascape.heightmap import Heightmap

NAME = "blender"
SUMMARY = "Blender: float32 TIFF displacement (Displace modifier) or a textured glb."
FORMATS = ("tiff", "glb")
#: the glb's terrain is meshed by ``ExportOptions.mesher``
TAKES_MESHER = True
#: Mesh compressions Blender's glTF importer reads: KHR_mesh_quantization since Blender 2.91
#: (glTF-Blender-IO pull request 1172); not EXT_meshopt_compression (issue 1460, open).
COMPRESSIONS = ("none", "quantize")


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    name = check_name(options.name)
    fmt = options.format or "tiff"
    if fmt not in FORMATS:
        raise InvalidParameterError(f"blender --format must be tiff or glb, got {fmt!r}")
    if options.tiles != 1:
        raise InvalidParameterError("blender takes one map (no tiles)")
    compress = options.compress or "none"
    if compress not in COMPRESSIONS:
        raise InvalidParameterError(
            f"blender --compress must be {' or '.join(COMPRESSIONS)} (Blender's glTF importer "
            f"reads KHR_mesh_quantization, not meshopt), got {compress!r}")
    if compress != "none" and fmt != "glb":
        raise InvalidParameterError("--compress is for the glb: add --format glb")
    if options.mesher is not None and fmt != "glb":
        raise InvalidParameterError("--mesher is for the glb: add --format glb")
    hm = heightmap
    ex, ez = hm.extent
    if fmt == "tiff":
        from terrascape.io.tiff import write_tiff

        path = write_tiff(hm, out / f"{name}.tif", force=options.force)
        lines = [
            f"Blender displacement for {name} (written by terrascape)",
            "",
            f"Add > Mesh > Plane; Size 1; scale X {ex:.6g}  Y {ez:.6g}  Z 1 (apply scale)",
            f"Edit mode > Subdivide: {hm.cols - 1} × {hm.rows - 1} cuts (one vertex per sample)"
            " or a Subdivision Surface (Simple) modifier",
            f"Displace modifier: texture = Image {path.name}, Color Space Non-Color, "
            "Extension Extend; Texture Coordinates UV; Direction Z; Strength 1; Midlevel 0",
            f"Heights are real world units: {hm.min:.6g} … {hm.max:.6g}",
            f"Sample spacing {hm.spacing[0]:.6g} × {hm.spacing[1]:.6g}; the TIFF's first row is "
            "the plane's +Y edge (north)",
        ]
    else:
        from terrascape.export.glb import write_terrain_glb
        from terrascape.lod.mesh_checks import max_vertical_error
        from terrascape.lod.static_meshers import static_mesher

        max_error = 0.5 if options.max_error is None else options.max_error
        mesher = static_mesher(options.mesher).name
        path, mesh = write_terrain_glb(hm, out / f"{name}.glb", max_error=max_error,
                                       force=options.force, objects=objects_for(options, hm),
                                       quantize=compress == "quantize", mesher=mesher)
        measured = max_vertical_error(hm, mesh.grid_triangles())
        lines = [
            f"Blender glTF import for {name} (written by terrascape)",
            "",
            f"File > Import > glTF 2.0 (.glb) > {path.name}; defaults (+Y Up converted)",
            f"{len(mesh.faces)} triangles ({mesher} mesher), maximum vertical error "
            f"{measured:.4g} world units (measured on every sample; asked {max_error:g})",
            *(["Quantized (KHR_mesh_quantization: 16-bit positions, 8-bit normals): "
               "Blender 2.91 or newer"] if compress == "quantize" else []),
            f"Size: {ex:.6g} × {ez:.6g}, heights {hm.min:.6g} … {hm.max:.6g} (metres)",
        ]
    note = write_text(out / f"{name}_import.txt", "\n".join(lines) + "\n", force=options.force)
    if fmt == "glb":  # the objects are in the glb, instanced
        return [path, note]
    return [path, note, *write_engine_instances(NAME, hm, out, name, options)]
