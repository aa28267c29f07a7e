"""Unity terrain: RAW 16-bit little-endian heightmaps, RGBA alphamaps, ``Name_X_Z`` tiles.

Unity's Terrain "Import Raw…" takes a square ``2**n + 1`` heightmap from 33 to 4097 samples,
16-bit, byte order "Windows" (little-endian). Codes 0…65535 span the terrain's height
("Terrain Height" = max − min in the import dialog; the terrain's Y position = min). Unity's
first RAW row is the terrain's z = 0 edge (south); terrascape's row 0 is north, so the rows
are written south first and imported with "Flip Vertically" off — ``--flip`` writes image
order (north first) for "Flip Vertically" on. Splat alphamaps: one RGBA PNG per 4 texture
layers (``Name_splat0.png`` = layers 0–3 …), at ``resolution − 1`` (Unity's power-of-two
control texture), rows in the same order as the RAW. Tiles: ``Name_X_Z.raw`` with X along +x
(columns) and Z along +z (north), neighbours sharing their edge samples, as Unity's
neighbouring terrains need.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

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
)
from terrascape.export.instances import write_engine_instances
from terrascape.heightmap import Heightmap

NAME = "unity"
SUMMARY = "Unity terrain: RAW 16-bit (2**n+1, 33…4097), RGBA alphamaps, Name_X_Z tiles."
SIZES = (33, 65, 129, 257, 513, 1025, 2049, 4097)


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    out = check_out_dir(out_dir)
    name = check_name(options.name)
    accepted = tiled_sizes(SIZES, options.tiles)
    hm = fit_to_sizes(heightmap, accepted, options.fit, square=True,
                      what=f"Unity ({options.tiles}×{options.tiles} tiles)"
                      if options.tiles > 1 else "Unity")
    lo, hi = hm.min, hm.max
    codes = uint16_codes(hm.heights, lo, hi)
    # Unity's row 0 is z = 0 (south); ours is north: flip unless the user asked for image order
    ordered = codes if options.flip else codes[::-1]
    written: list[Path] = []
    blocks = split_tiles(ordered, options.tiles)
    for (i, j), block in blocks.items():
        stem = name if options.tiles == 1 else f"{name}_{j}_{i}"
        written.append(write_bytes(out / f"{stem}.raw", block.astype("<u2").tobytes(),
                                   force=options.force))
    tile_res = next(iter(blocks.values())).shape[0]
    layer_names: list[str] = []
    if options.layers:
        control = tile_res - 1
        layer_names, w = layer_weights(hm)  # the map's own grid: tiles · control + 1 a side
        w = w if options.flip else w[::-1]
        for i, j in blocks:
            sub = w[i * control:(i + 1) * control, j * control:(j + 1) * control]
            stem = name if options.tiles == 1 else f"{name}_{j}_{i}"
            for k in range(0, len(layer_names), 4):
                rgba = np.zeros((control, control, 4), np.uint8)
                part = sub[..., k:k + 4]
                rgba[..., :part.shape[2]] = weight_codes(part)
                written.append(write_png(out / f"{stem}_splat{k // 4}.png", rgba,
                                         force=options.force))
    ex, ez = hm.extent
    tile_w, tile_l = ex / options.tiles, ez / options.tiles
    lines = [
        f"Unity terrain import for {name} (written by terrascape)",
        "",
        "Terrain > Terrain Settings > Texture Resolutions (On Terrain Data) > Import Raw…",
        f"  Depth: Bit 16    Resolution: {tile_res}    Byte Order: Windows",
        f"  Flip Vertically: {'ON' if options.flip else 'off'}",
        f"  Terrain Size: width {tile_w:.6g}  length {tile_l:.6g}  height {hi - lo:.6g}",
        f"Terrain position Y: {lo:.6g} (the lowest height; RAW code 0)",
        f"Height range in world units: {lo:.6g} … {hi:.6g}; code c is {lo:.6g} + c × "
        f"{(hi - lo) / 65535:.6g}",
        f"Sample spacing: {hm.spacing[0]:.6g} × {hm.spacing[1]:.6g}",
    ]
    if options.tiles > 1:
        lines += [
            f"Tiles: {options.tiles}×{options.tiles}, {name}_X_Z.raw; X = column (+x), "
            "Z = row from the south (+z); place tile X_Z at "
            f"({tile_w:.6g}·X, {lo:.6g}, {tile_l:.6g}·Z) and set neighbours "
            "(Terrain.SetNeighbors) — edges share their samples",
        ]
    if layer_names:
        lines += [
            f"Alphamaps: {name}[_X_Z]_splatN.png, {tile_res - 1}×{tile_res - 1} RGBA, "
            "Control Texture Resolution " + str(tile_res - 1),
            "  layer order: " + ", ".join(f"{k}={n}" for k, n in enumerate(layer_names))
            + " (splat0 = layers 0–3 in R, G, B, A; splat1 = layers 4–7 …)",
        ]
    written.append(write_text(out / f"{name}_import.txt", "\n".join(lines) + "\n",
                              force=options.force))
    return written + write_engine_instances(NAME, hm, out, name, options)
