"""``terrascape bench shade``: shadow maps (fast sweep vs Marghidanu's ray walk), lightmaps,
normals.

Terrain: diamond-square (Filipović 2008 §2.2) normalised to a relief of 5 % of the map width,
spacing 1 — about a 60 km DEM at 30 m with 2 km of relief at 2049². Azimuths include
axis-aligned, diagonal and general directions, since the sweep runs along rows or columns
depending on the light.
"""

from __future__ import annotations

import numpy as np

from terrascape.bench import BenchTable, best_of
from terrascape.heightmap import Heightmap

RELIEF = 0.05
AZIMUTHS = (0.0, 30.0, 135.0, 250.0)
FAST_ELEVATIONS = (5.0, 20.0, 45.0)
REFERENCE_ELEVATIONS = (5.0, 45.0)
REFERENCE_MAX = 2049


def terrain(size: int, seed: int = 1) -> Heightmap:
    """Benchmark terrain: diamond-square, normalised to the benchmark relief."""
    from terrascape.generate import diamond_square

    hm = diamond_square(size, roughness=1.0, decay="halve", seed=seed)
    return hm.normalised(0.0, RELIEF * (size - 1))


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.lighting import (
        lightmap,
        normal_map,
        shadow_mask,
        shadow_mask_reference,
        soft_shadow,
    )

    sizes = (513, 1025) if quick else (513, 1025, 2049, 4097)
    repeat = 1 if quick else 3
    shadows = BenchTable(
        "Shadow map: fast sweep vs reference ray walk (Filipović 2008 §3.2.2)",
        ["size", "az °", "el °", "fast s", "ref s", "ref/fast", "differ %", "shadow %"],
    )
    other = BenchTable(
        "Normals, lightmap, soft shadows (fast method)",
        ["size", "normals s", "lightmap s", "soft shadow (8 slices) s"],
    )
    shadow_mask(terrain(33).heights, 30.0, 20.0)  # compile outside the timings
    shadow_mask_reference(terrain(33).heights, 30.0, 20.0)
    for n in sizes:
        hm = terrain(n)
        for el in FAST_ELEVATIONS:
            for az in AZIMUTHS:
                t_fast = best_of(lambda hm=hm, az=az, el=el: shadow_mask(hm, az, el), repeat=repeat)
                fast = shadow_mask(hm, az, el)
                row = [n, az, el, t_fast, "-", "-", "-", 100.0 * float(fast.mean())]
                if n <= REFERENCE_MAX and el in REFERENCE_ELEVATIONS:
                    t_ref = best_of(
                        lambda hm=hm, az=az, el=el: shadow_mask_reference(hm, az, el),
                        repeat=1, warmup=0,
                    )
                    ref = shadow_mask_reference(hm, az, el)
                    row[4:7] = [t_ref, t_ref / t_fast, 100.0 * float(np.mean(fast != ref))]
                shadows.rows.append(row)
        other.rows.append([
            n,
            best_of(lambda hm=hm: normal_map(hm), repeat=repeat),
            best_of(lambda hm=hm: lightmap(hm, 135.0, 20.0), repeat=repeat),
            best_of(lambda hm=hm: soft_shadow(hm, 135.0, 20.0), repeat=1),
        ])
    shadows.notes += [
        f"terrain: diamond-square, relief {RELIEF:.0%} of the width, spacing 1",
        f"reference only up to {REFERENCE_MAX}² and at {REFERENCE_ELEVATIONS} degrees; "
        "best of 1 run, fast best of "
        f"{repeat}",
        "differ % = share of samples where fast and reference disagree; "
        "shadow % = share of samples in shadow",
    ]
    return [shadows, other]
