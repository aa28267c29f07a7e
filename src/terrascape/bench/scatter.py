"""``terrascape bench scatter``: scattering trees, rocks and buildings by the default rules,
and Poisson-disk dart throwing near the packing limit.

Terrain: diamond-square, spacing 4 m (a 1025² map is 4.1 km wide), relief 20 % of the
width (the generators' default). The dart-throwing table uses a flat map and one rule at a
share of the most that fit at its spacing (``PACKING / spacing²``), where the throwing slows.
"""

from __future__ import annotations

import numpy as np

from terrascape.bench import BenchTable, best_of


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape import Heightmap
    from terrascape.generate import generate
    from terrascape.objects import ScatterRule, scatter
    from terrascape.objects.rules import fit_limit_per_hectare

    sizes = (257, 513) if quick else (257, 513, 1025, 2049)
    repeat = 1 if quick else 3
    rules = BenchTable("Scatter by the default rules (seed 1)",
                       ["size", "hectares", "objects", "scatter s", "objects/s",
                        "density factor"])
    scatter(generate("diamond-square", 33, seed=1, spacing=4.0), seed=1)  # compile
    for n in sizes:
        hm = generate("diamond-square", n, seed=7, spacing=4.0)
        inst = scatter(hm, seed=1)
        t = best_of(lambda hm=hm: scatter(hm, seed=1), repeat=repeat, warmup=0)
        ex, ez = hm.extent
        rules.rows.append([n, ex * ez / 1e4, len(inst), t, len(inst) / t,
                           inst.metadata["density_factor"]])
    rules.notes += ["terrain: diamond-square seed 7, spacing 4 m, relief 20 % of the width",
                    f"best of {repeat}; includes slope, curvature and material weights",
                    "density factor < 1: the built-in rules thinned to stay under 200,000"]

    darts = BenchTable("Poisson-disk dart throwing on a flat 1025² map (spacing 4 m)",
                       ["share of the fit limit", "asked", "placed", "scatter s"])
    flat = Heightmap(np.zeros((1025, 1025), np.float32), 4.0)
    limit = fit_limit_per_hectare(4.0)
    for share in ((0.25, 1.0) if quick else (0.1, 0.25, 0.5, 0.75, 1.0)):
        rule = ScatterRule("trees", ("conifer",), density=share * limit, spacing=4.0)
        inst = scatter(flat, rule, seed=1, max_objects=10_000_000)
        t = best_of(lambda rule=rule: scatter(flat, rule, seed=1, max_objects=10_000_000),
                    repeat=1, warmup=0)
        r = inst.metadata["rules"][0]
        darts.rows.append([share, r["target"], r["placed"], t])
    darts.notes += [f"fit limit {limit:.0f} objects per hectare at 4 m (0.4 / spacing²)",
                    "placed < asked: the attempts (30 per object asked) ran out"]
    return [rules, darts]
