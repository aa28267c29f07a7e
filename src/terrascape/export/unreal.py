"""Unreal Engine landscape: 16-bit grayscale PNG or ``.r16``, weight maps, ``_x0_y0`` tiles.

Unreal's Landscape mode imports a heightmap whose size is one of its recommended landscape
sizes (quads per component × components + 1: 127, 253, 505, 1009, 2017, 4033, 8129 and the
others of Epic's table) so no edge is lost or resampled. A 16-bit code ``c`` means
``(c − 32768) / 128 × ZScale / 100`` metres relative to the landscape actor, so the codes are
spread over the height range with ``ZScale = (max − min) × 100 / 512`` and the actor at
``Z = (min + max) / 2 × 100`` cm; X/Y scale = spacing × 100 (cm per sample). Weight maps: one
8-bit grayscale PNG per texture layer (``Name_layer_<layer>.png``). Tiles for World Partition /
World Composition: ``Name_x<i>_y<j>.png`` (x = column, y = row), sharing edge samples.
"""

from __future__ import annotations

from pathlib import Path

from terrascape.errors import InvalidParameterError
from terrascape.export._common import (
    ExportOptions,
    check_name,
    check_out_dir,
    fit_to_sizes,
    layer_weights,
    one_unit,
    split_tiles,
    tiled_sizes,
    uint16_codes,
    weight_codes,
    write_bytes,
    write_png,
    write_text,
    write_world_file,
)
from terrascape.export.instances import write_engine_instances
from terrascape.heightmap import Heightmap

NAME = "unreal"
SUMMARY = "Unreal landscape: 16-bit PNG or r16 at the recommended sizes (127…8129), weight maps."
#: Epic's recommended landscape sizes (Landscape Technical Guide, "Recommended Landscape Sizes")
SIZES = (127, 253, 505, 1009, 2017, 4033, 8129)
FORMATS = ("png", "r16")


def z_scale(lo: float, hi: float) -> float:
    """The Landscape Z scale (percent) that maps codes 0…65535 onto ``[lo, hi]`` metres."""
    return max(hi - lo, 1e-6) * 100.0 / 512.0


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    name = check_name(options.name)
    fmt = options.format or "png"
    if fmt not in FORMATS:
        raise InvalidParameterError(f"unreal --format must be png or r16, got {fmt!r}")
    accepted = tiled_sizes(SIZES, options.tiles)
    hm = fit_to_sizes(heightmap, accepted, options.fit, square=False, what="Unreal")
    lo, hi = hm.min, hm.max
    codes = uint16_codes(hm.heights, lo, hi)
    written: list[Path] = []
    blocks = split_tiles(codes, options.tiles)
    step_r, step_c = (hm.rows - 1) // options.tiles, (hm.cols - 1) // options.tiles
    for (i, j), block in blocks.items():
        stem = name if options.tiles == 1 else f"{name}_x{j}_y{i}"
        if fmt == "png":
            written.append(write_png(out / f"{stem}.png", block, force=options.force))
            # GIS tools place the PNG (Unreal ignores these files)
            written += write_world_file(out / f"{stem}.png", hm, row=i * step_r,
                                        col=j * step_c, force=options.force)
        else:
            written.append(write_bytes(out / f"{stem}.r16", block.astype("<u2").tobytes(),
                                       force=options.force))
    layer_names: list[str] = []
    if options.layers:
        layer_names, w = layer_weights(hm)
        for k, layer in enumerate(layer_names):
            grey = weight_codes(w[..., k])
            for (i, j), block in split_tiles(grey, options.tiles).items():
                stem = name if options.tiles == 1 else f"{name}_x{j}_y{i}"
                written.append(write_png(out / f"{stem}_layer_{layer}.png", block,
                                         force=options.force))
    rows, cols = next(iter(blocks.values())).shape
    zs = z_scale(lo, hi)
    tiled = "  (tiled: Import Tiled / World Partition, pattern _x#_y#)" if options.tiles > 1 else ""
    lines = [
        f"Unreal Engine landscape import for {name} (written by terrascape)",
        "",
        "Landscape mode > Manage > New > Import from File",
        f"  Heightmap File: {name}{'_x0_y0' if options.tiles > 1 else ''}.{fmt}"
        f"{tiled}",
        f"  Resolution: {cols} × {rows} (overall {hm.cols} × {hm.rows})",
        f"  Location: X 0  Y 0  Z {(lo + hi) / 2 * 100:.6g}",
        f"  Scale: X {hm.spacing[0] * 100:.6g}  Y {hm.spacing[1] * 100:.6g}  Z {zs:.6g}",
        f"Height range: {lo:.6g} … {hi:.6g} m (code 0 … 65535); one code = "
        f"{(hi - lo) / 65535:.6g} m",
    ]
    if layer_names:
        lines.append("Layers (Landscape > Paint > Target Layers > Import): "
                     + ", ".join(f"{n} = {name}_layer_{n}.png" for n in layer_names))
    written.append(write_text(out / f"{name}_import.txt", "\n".join(lines) + "\n",
                              force=options.force))
    return written + write_engine_instances(NAME, hm, out, name, options)
