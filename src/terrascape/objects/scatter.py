"""Scatter objects on a terrain by rules: Poisson-disk dart throwing weighted by suitability.

For each rule, in priority order (:mod:`terrascape.objects.rules`):

1. the suitability of each grid sample (the product of the rule's slope, height, curvature,
   mask and material bands; zero below the sea level) is averaged onto the grid's cells;
2. the rule asks for ``density × Σ cell suitability × cell area`` objects (rounded);
3. candidate points are drawn from a seeded generator — a cell with probability proportional
   to its suitability, then a uniform point inside it — and accepted in order when no object
   placed so far (by this rule or an earlier one) is closer than the larger of the two rules'
   spacings, until the rule has its count or has used its attempts (``ATTEMPTS`` per object
   asked). The test uses a background grid of cells at least the smallest spacing wide,
   as in Bridson's fast Poisson-disk sampling; objects with a spacing wider than four cells are
   kept in a short separate list and checked against every candidate.
4. each accepted object gets a mesh of its rule, a scale in the rule's range and a yaw in
   [0, 2π) from a second seeded stream, and the height of the drawn full-resolution surface
   (:func:`~terrascape.objects.surface.surface_height`).

Everything is sequential on seeded streams (``numpy.random.SeedSequence([seed, rule])``), so
the same seed gives the same bytes whatever the thread count.

A rule that asks for more than fit at its spacing (``PACKING / spacing²`` per square world
unit) or rules that together ask for more than ``max_objects`` raise
:class:`~terrascape.errors.InvalidParameterError` naming the numbers — except the built-in
rules, whose densities are lowered by one common factor to fit the cap on very large maps.

References
----------
.. [1] R. Bridson, "Fast Poisson disk sampling in arbitrary dimensions", SIGGRAPH sketches,
   2007.
.. [2] J. Feder, "Random sequential adsorption", J. Theor. Biol. 87(2), 1980.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from terrascape._numba import CACHE, FASTMATH, njit
from terrascape._validate import check_finite, check_positive, make_rng
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.meshes import BUILTIN_NAMES, builtin_mesh
from terrascape.objects.model import Instances, ObjectMesh
from terrascape.objects.rules import (
    HECTARE,
    RuleSet,
    ScatterRule,
    default_rules,
    fit_limit_per_hectare,
    ground_fields,
    suitability,
)
from terrascape.objects.surface import surface_height

__all__ = ["ATTEMPTS", "scatter"]

#: Candidate points thrown per object a rule asks for, at most.
ATTEMPTS = 30
#: Objects whose spacing is at most this many grid cells are kept in the grid (a candidate
#: looks ``_REACH`` cells around it); wider ones (buildings) in the separate list.
_REACH = 4.0
#: The background grid has at most this many cells.
_MAX_GRID_CELLS = 1 << 22


@njit(cache=CACHE, fastmath=FASTMATH)
def _place(cand_x, cand_z, radius, want, px, pz, pr, count, head, nxt, cell, grid_cols,
           grid_rows, big, n_big, margin):
    """Accept candidates in order while ``want`` more are needed; returns ``(count, used)``.

    Placed objects ``0 … count-1`` are ``(px, pz)`` with spacing ``pr``; those with spacing
    ≤ ``_REACH`` cells are linked in the grid (``head``/``nxt``), the others listed in ``big``.
    """
    accepted = 0
    reach = max(radius, _REACH * cell)
    span = int(reach / cell) + 1  # one cell more than needed at most
    for k in range(cand_x.shape[0]):
        if accepted >= want:
            return count, k
        x = cand_x[k]
        z = cand_z[k]
        ok = True
        for b in range(n_big):
            p = big[b]
            rr = max(radius, pr[p]) + margin
            if (px[p] - x) ** 2 + (pz[p] - z) ** 2 < rr * rr:
                ok = False
                break
        if ok:
            ci = min(int(x / cell), grid_cols - 1)
            cj = min(int(z / cell), grid_rows - 1)
            for gj in range(max(0, cj - span), min(grid_rows, cj + span + 1)):
                if not ok:
                    break
                for gi in range(max(0, ci - span), min(grid_cols, ci + span + 1)):
                    p = head[gj * grid_cols + gi]
                    while p >= 0:
                        rr = max(radius, pr[p]) + margin
                        if (px[p] - x) ** 2 + (pz[p] - z) ** 2 < rr * rr:
                            ok = False
                            break
                        p = nxt[p]
                    if not ok:
                        break
        if ok:
            px[count] = x
            pz[count] = z
            pr[count] = radius
            if radius > _REACH * cell:
                big[n_big] = count
                n_big += 1
            else:
                ci = min(int(x / cell), grid_cols - 1)
                cj = min(int(z / cell), grid_rows - 1)
                g = cj * grid_cols + ci
                nxt[count] = head[g]
                head[g] = count
            count += 1
            accepted += 1
    return count, cand_x.shape[0]


def _cell_weights(weight: np.ndarray, heights: np.ndarray, sea_level: float | None
                  ) -> np.ndarray:
    """Sample suitability averaged onto the cells between samples; with a sea level, a cell
    with any corner below it gets 0 (so no point of a suitable cell lies under the sea)."""
    w = 0.25 * (weight[:-1, :-1] + weight[1:, :-1] + weight[:-1, 1:] + weight[1:, 1:])
    if sea_level is not None:
        low = np.minimum(np.minimum(heights[:-1, :-1], heights[1:, :-1]),
                         np.minimum(heights[:-1, 1:], heights[1:, 1:]))
        w[low < sea_level] = 0.0
    return w


def _candidates(rng: np.random.Generator, cdf: np.ndarray, cols: int, dx: float, dz: float,
                n: int) -> tuple[np.ndarray, np.ndarray]:
    cell = np.searchsorted(cdf, rng.random(n) * cdf[-1], side="right")
    cell = np.minimum(cell, len(cdf) - 1)
    r, c = np.divmod(cell, cols)
    jitter = rng.random((n, 2))
    return (c + jitter[:, 0]) * dx, (r + jitter[:, 1]) * dz


def _as_ruleset(rules, sea_level, max_objects, masks) -> RuleSet:
    if rules is None:
        return default_rules(masks=tuple(masks or ()), sea_level=sea_level,
                             **({} if max_objects is None else {"max_objects": max_objects}))
    if isinstance(rules, ScatterRule):
        rules = (rules,)
    if isinstance(rules, RuleSet):
        ruleset = rules
    elif isinstance(rules, Sequence) and not isinstance(rules, str):
        ruleset = RuleSet(tuple(rules))
    else:
        raise InvalidParameterError(
            f"rules must be a RuleSet, ScatterRule(s) or None, got {type(rules).__name__}")
    changes: dict[str, Any] = {}
    if sea_level is not None:
        changes["sea_level"] = sea_level
    if max_objects is not None:
        changes["max_objects"] = max_objects
    if changes:
        import dataclasses

        ruleset = dataclasses.replace(ruleset, **changes)
    return ruleset


def _mesh_library(ruleset: RuleSet, extra: Mapping[str, ObjectMesh] | None
                  ) -> tuple[tuple[ObjectMesh, ...], list[list[int]]]:
    """The meshes the rules name (in first-use order) and, per rule, their indices."""
    user = dict(ruleset.meshes)
    user.update(extra or {})
    for name, mesh in user.items():
        if not isinstance(mesh, ObjectMesh):
            raise InvalidParameterError(f"mesh {name!r} must be an ObjectMesh")
    order: list[str] = []
    per_rule: list[list[int]] = []
    for rule in ruleset.rules:
        idx = []
        for name in rule.meshes:
            if name not in user and name not in BUILTIN_NAMES:
                known = sorted(set(user) | set(BUILTIN_NAMES))
                raise InvalidParameterError(
                    f"rule {rule.name!r}: unknown mesh {name!r}; available: {', '.join(known)}")
            if name not in order:
                order.append(name)
            idx.append(order.index(name))
        per_rule.append(idx)
    meshes = tuple(user[n] if n in user else builtin_mesh(n) for n in order)
    return meshes, per_rule


def scatter(
    heightmap: Heightmap,
    rules: RuleSet | Sequence[ScatterRule] | ScatterRule | None = None,
    *,
    seed: int = 0,
    exaggeration: float = 1.0,
    masks: Mapping[str, Any] | None = None,
    sea_level: float | None = None,
    max_objects: int | None = None,
    meshes: Mapping[str, ObjectMesh] | None = None,
) -> Instances:
    """Place objects on ``heightmap`` by ``rules`` (see the module docstring).

    Parameters
    ----------
    heightmap
        The terrain; world units are taken as metres for the densities per hectare.
    rules
        A :class:`~terrascape.objects.rules.RuleSet`, one or more
        :class:`~terrascape.objects.rules.ScatterRule`, or ``None`` for the built-in rules
        (:func:`~terrascape.objects.rules.default_rules`).
    seed
        Seeds every random choice (same seed, same bytes).
    exaggeration
        The vertical scale the terrain is drawn with: object feet sit on the drawn surface.
    masks
        Optional erosion masks ``{"flow" | "deposition" | "wear" | "water": (rows, cols)}``.
    sea_level
        Nothing stands on ground below this height (world units, before exaggeration);
        overrides the rule set's.
    max_objects
        The cap (default: the rule set's, 200 000).
    meshes
        The user's meshes ``{name: ObjectMesh}`` the rules may name.

    Returns
    -------
    Instances
        Positions ``(x, y, z)`` of the feet, scales, yaws, kinds; ``metadata["rules"]`` lists
        each rule's asked and placed counts.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(
            f"scatter expects a terrascape Heightmap, got {type(heightmap).__name__}")
    make_rng(seed)
    seed = int(seed)
    exaggeration = check_positive(check_finite(exaggeration, "exaggeration"), "exaggeration")
    rows, cols = heightmap.shape
    if rows < 2 or cols < 2:
        raise InvalidParameterError(f"scatter needs at least 2×2 samples, got {cols}×{rows}")
    ruleset = _as_ruleset(rules, sea_level, max_objects, masks)
    library, per_rule = _mesh_library(ruleset, meshes)
    ground = ground_fields(heightmap, masks, seed=seed)
    dx, dz = heightmap.spacing
    cell_area = dx * dz

    # What each rule asks for, before placing anything (so the cap error comes first).
    cdfs: list[np.ndarray | None] = []
    asked: list[float] = []
    for rule in ruleset.rules:
        if rule.density > fit_limit_per_hectare(rule.spacing) * (1 + 1e-9):
            raise InvalidParameterError(
                f"rule {rule.name!r} asks for {rule.density:g} objects per hectare with a "
                f"spacing of {rule.spacing:g}, but at most "
                f"{fit_limit_per_hectare(rule.spacing):.4g} per hectare fit that far apart; "
                "lower its density or its spacing")
        weights = _cell_weights(suitability(rule, ground), heightmap.heights,
                                ruleset.sea_level).ravel()
        cdf = np.cumsum(weights)
        total = float(cdf[-1]) if cdf.size else 0.0
        asked.append(rule.density * total * cell_area / HECTARE)
        cdfs.append(cdf if total > 0 else None)
    factor = 1.0
    total_asked = int(sum(round(a) for a in asked))
    if total_asked > ruleset.max_objects:
        if not ruleset.adapt_density:
            raise InvalidParameterError(
                f"the rules ask for {total_asked:,} objects on this map, more than the cap of "
                f"{ruleset.max_objects:,}; lower the densities or raise max_objects")
        factor = ruleset.max_objects / sum(asked)
    counts = [min(round(a * factor), ruleset.max_objects) for a in asked]
    while sum(counts) > ruleset.max_objects:  # rounding several rules up can pass the cap
        counts[int(np.argmax(counts))] -= 1

    # Background grid for the spacing test.
    ex, ez = heightmap.extent
    min_spacing = min(r.spacing for r in ruleset.rules) if ruleset.rules else 1.0
    cell = max(min_spacing, math.sqrt(ex * ez / _MAX_GRID_CELLS), 1e-9)
    grid_cols = max(1, math.ceil(ex / cell) + 1)
    grid_rows = max(1, math.ceil(ez / cell) + 1)
    capacity = sum(counts)
    px = np.empty(capacity, np.float64)
    pz = np.empty(capacity, np.float64)
    pr = np.empty(capacity, np.float64)
    nxt = np.full(capacity, -1, np.int64)
    big = np.empty(capacity, np.int64)
    head = np.full(grid_cols * grid_rows, -1, np.int64)
    # float32 positions round by up to ½ ulp each: keep that much farther apart so the
    # spacing still holds after the Instances store them as float32
    margin = 4.0 * float(np.finfo(np.float32).eps) * max(ex, ez, 1.0)

    count = 0
    kinds, scales, yaws, report = [], [], [], []
    for index, (rule, cdf, want) in enumerate(zip(ruleset.rules, cdfs, counts, strict=True)):
        start = count
        if cdf is not None and want > 0:
            rng = np.random.default_rng(np.random.SeedSequence([seed, index, 0]))
            budget = ATTEMPTS * want + 100
            thrown = 0
            while count - start < want and thrown < budget:
                batch = min(budget - thrown, max(1024, 2 * (want - (count - start))))
                cx, cz = _candidates(rng, cdf, cols - 1, dx, dz, batch)
                n_big = int(np.count_nonzero(pr[:count] > _REACH * cell))
                count, used = _place(cx, cz, rule.spacing, want - (count - start), px, pz, pr,
                                     count, head, nxt, cell, grid_cols, grid_rows, big, n_big,
                                     margin)
                thrown += used
        placed = count - start
        rng = np.random.default_rng(np.random.SeedSequence([seed, index, 1]))
        choice = rng.integers(0, len(per_rule[index]), placed)
        kinds.append(np.asarray(per_rule[index], np.int32)[choice])
        scales.append(rng.uniform(rule.scale[0], rule.scale[1], placed))
        yaws.append(rng.uniform(0.0, 2.0 * math.pi, placed))
        report.append({"name": rule.name, "meshes": list(rule.meshes),
                       "asked": round(asked[index]), "target": int(want),
                       "placed": int(placed)})
    # heights from the float32 coordinates the Instances keep, so y is the surface at them
    x = px[:count].astype(np.float32).astype(np.float64)
    z = pz[:count].astype(np.float32).astype(np.float64)
    y = surface_height(heightmap, x, z, exaggeration)
    positions = np.stack([x, y, z], axis=1)
    return Instances(
        library,
        np.concatenate(kinds) if kinds else np.zeros(0, np.int32),
        positions,
        np.concatenate(scales) if scales else np.zeros(0, np.float32),
        np.concatenate(yaws) if yaws else np.zeros(0, np.float32),
        metadata={"seed": seed, "exaggeration": exaggeration, "rules": report,
                  "density_factor": factor, "sea_level": ruleset.sea_level,
                  "max_objects": ruleset.max_objects},
    )
