"""Benchmark: texture synthesis by grid size (``terrascape bench texture``).

Computation only (no file I/O): the region texture (Filipović 2008 §3.1.1) at scale 1 with the
built-in 256-px materials, and the splat-map pipeline (Filipović 2008 §3.1.3): material ids from
height/slope rules, per-vertex alpha maps (32×32-cell blocks), RGBA packing. Sizes 513…4097;
``quick`` runs 513 and 1025. Built-in materials are cached after the warm-up call.
"""

from __future__ import annotations

import os

from terrascape.bench import BenchTable, best_of

FULL_SIZES = (513, 1025, 2049, 4097)
QUICK_SIZES = (513, 1025)


def _terrain(n: int):
    """A diamond-square map with heights 0…n/4 world units (spacing 1): realistic slopes."""
    from terrascape.generate import diamond_square

    return diamond_square(n, seed=1).normalised(0.0, n / 4.0)


def run(quick: bool = False) -> list[BenchTable]:
    """Time region texture (with and without jitter) and the splat-map stages."""
    import numba

    from terrascape.texture import (
        default_regions,
        material_ids_from_rules,
        pack_splat_maps,
        region_texture,
        splat_weights,
    )

    sizes = QUICK_SIZES if quick else FULL_SIZES
    region_table = BenchTable(
        title="Region texture (ms) by grid side, scale 1, slope rule on",
        columns=["variant", *[f"{n}²" for n in sizes]],
    )
    splat_table = BenchTable(
        title="Splat maps (ms) by grid side, 5 layers, 32×32-cell blocks",
        columns=["stage", *[f"{n}²" for n in sizes]],
    )
    rows_r: dict[str, list] = {"no jitter": [], "jitter 0.3": []}
    rows_s: dict[str, list] = {"material ids (rules)": [], "alpha maps (splat_weights)": [],
                               "pack RGBA": [], "total": []}
    for n in sizes:
        hm = _terrain(n)
        regions = default_regions(hm)
        repeat = 5 if n <= 1025 else (3 if n <= 2049 else 1)
        rows_r["no jitter"].append(
            best_of(lambda hm=hm: region_texture(hm), repeat=repeat) * 1e3)
        rows_r["jitter 0.3"].append(
            best_of(lambda hm=hm: region_texture(hm, jitter=0.3, seed=1), repeat=repeat) * 1e3)
        ids = material_ids_from_rules(hm, regions)
        weights = splat_weights(ids, len(regions))
        t_ids = best_of(lambda hm=hm, r=regions: material_ids_from_rules(hm, r), repeat=repeat)
        t_w = best_of(lambda ids=ids: splat_weights(ids, 5), repeat=repeat)
        t_p = best_of(lambda w=weights: pack_splat_maps(w), repeat=repeat)
        del weights
        for key, t in zip(rows_s, (t_ids, t_w, t_p, t_ids + t_w + t_p), strict=True):
            rows_s[key].append(t * 1e3)
    region_table.rows = [[k, *v] for k, v in rows_r.items()]
    splat_table.rows = [[k, *v] for k, v in rows_s.items()]
    env = (f"best of 1–5 runs after a warm-up; numba threads: {numba.get_num_threads()}, "
           f"CPUs: {os.cpu_count()}, load average at the end: {os.getloadavg()[0]:.2f}")
    region_table.notes += [env, "target (brief): region texture 2049² ≤ 500 ms",
                           "terrain: diamond-square, heights 0…side/4, spacing 1"]
    splat_table.notes += [env, "target (brief): splat maps 2049² ≤ 500 ms"]
    region_table.check_target("region texture 2049²", region_table.value("no jitter", "2049²"),
                              at_most=500, unit=" ms")
    splat_table.check_target("splat maps 2049²", splat_table.value("total", "2049²"),
                             at_most=500, unit=" ms")
    return [region_table, splat_table]
