"""Scatter rules: which meshes grow where, how densely, how far apart — and the defaults.

A :class:`ScatterRule` names one or more meshes, a density (objects per hectare where the
ground suits it fully; world units are taken as metres), a minimum spacing (the Poisson-disk
exclusion radius: no two objects closer than the larger of their two rules' spacings, across
rules too), per-object scale range, and any of these conditions on the ground, each a
:class:`Band`:

* ``slope`` — degrees (0 flat, 90 vertical), of the terrain as it is (no exaggeration);
* ``height`` — world units, or ``height_fraction`` — 0 at the lowest sample, 1 at the highest;
* ``curvature`` — the terrain material's curvature: the Laplacian of the (lightly smoothed)
  heights divided by its 90th percentile of magnitude and clipped to [−1, 1]; > 0 in concave
  hollows and valleys, < 0 on convex ridges and knolls;
* ``masks`` — the erosion masks of ``terrascape erode --masks`` (``flow``, ``deposition``,
  ``wear``, ``water``) scaled to [0, 1] as the terrain material reads them (flow and deposition
  by their 95th percentile);
* ``materials`` — the weights of the terrain material's layers (``grass``, ``meadow``,
  ``rock``, ``scree``, ``sediment``, ``snow``, ``water``; :func:`material_weights`).

A band is fully suitable between ``min`` and ``max`` and fades linearly to unsuitable over
``ramp`` outside them (``ramp = 0``: a hard edge). The suitability of a point is the product
of its rule's bands; with a sea level nothing stands on ground below it.

Rules files (TOML or JSON) hold the same fields; see ``docs/objects.md``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from scipy import ndimage

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap

__all__ = [
    "DEFAULT_MAX_OBJECTS",
    "MASK_NAMES",
    "Band",
    "RuleSet",
    "ScatterRule",
    "default_rules",
    "default_tree_rule",
    "fit_limit_per_hectare",
    "ground_fields",
    "rule_from_dict",
    "ruleset_from_dict",
    "suitability",
]

#: The cap on the objects one scatter may place, unless the rules say otherwise.
DEFAULT_MAX_OBJECTS = 200_000
#: Erosion masks a rule may read (those of ``terrascape erode --masks``).
MASK_NAMES: tuple[str, ...] = ("flow", "deposition", "wear", "water")
#: Poisson-disk objects at spacing r fit at most PACKING / r² per square world unit: 0.4 is
#: 57 % of the jammed random sequential packing (0.547 · 4/π ≈ 0.697 / r², Feder 1980), which
#: dart throwing reaches in a bounded number of attempts.
PACKING = 0.4
HECTARE = 10_000.0


def fit_limit_per_hectare(spacing: float) -> float:
    """The most objects per hectare that fit at ``spacing`` (see :data:`PACKING`)."""
    return PACKING / (float(spacing) ** 2) * HECTARE


def _number(value: Any, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise InvalidParameterError(f"{what} must be a number, got {value!r}")
    v = float(value)
    if math.isnan(v):
        raise InvalidParameterError(f"{what} must be a number, got NaN")
    return v


@dataclass(frozen=True)
class Band:
    """Suitable from ``lo`` to ``hi``, fading linearly to 0 over ``ramp`` outside."""

    lo: float = -math.inf
    hi: float = math.inf
    ramp: float = 0.0

    def __post_init__(self) -> None:
        lo = _number(self.lo, "a band's min")
        hi = _number(self.hi, "a band's max")
        ramp = _number(self.ramp, "a band's ramp")
        if lo > hi:
            raise InvalidParameterError(f"a band needs min ≤ max, got min {lo:g} > max {hi:g}")
        if not (ramp >= 0 and math.isfinite(ramp)):
            raise InvalidParameterError(f"a band's ramp must be finite and ≥ 0, got {ramp:g}")
        object.__setattr__(self, "lo", lo)
        object.__setattr__(self, "hi", hi)
        object.__setattr__(self, "ramp", ramp)

    def weight(self, values: np.ndarray) -> np.ndarray:
        """float64 suitability in [0, 1] of ``values``."""
        v = np.asarray(values, np.float64)
        if self.ramp == 0:
            return ((v >= self.lo) & (v <= self.hi)).astype(np.float64)
        # 1 + distance inside the band in ramps, from either edge: ≥ 1 inside, ≤ 0 a ramp out
        # (an infinite edge gives +inf, never the minimum)
        with np.errstate(invalid="ignore"):
            w = np.minimum(v - self.lo, self.hi - v)
        w /= self.ramp
        w += 1.0
        return np.clip(w, 0.0, 1.0, out=w)

    @classmethod
    def parse(cls, value: Any, what: str) -> Band:
        """From ``[min, max]``, ``[min, max, ramp]`` or ``{min =, max =, ramp =}`` (each key
        optional; a missing min/max is unbounded)."""
        if isinstance(value, Band):
            return value
        if isinstance(value, Mapping):
            unknown = sorted(set(value) - {"min", "max", "ramp"})
            if unknown:
                raise InvalidParameterError(
                    f"{what}: unknown key {unknown[0]!r}; a band takes min, max and ramp")
            return cls(value.get("min", -math.inf), value.get("max", math.inf),
                       value.get("ramp", 0.0))
        if isinstance(value, Sequence) and not isinstance(value, str) and len(value) in (2, 3):
            try:
                return cls(*value)
            except InvalidParameterError as exc:
                raise InvalidParameterError(f"{what}: {exc}") from None
        raise InvalidParameterError(
            f"{what} must be [min, max], [min, max, ramp] or {{min, max, ramp}}, got {value!r}")

    def as_dict(self) -> dict:
        out: dict = {}
        if math.isfinite(self.lo):
            out["min"] = self.lo
        if math.isfinite(self.hi):
            out["max"] = self.hi
        if self.ramp:
            out["ramp"] = self.ramp
        return out


_BAND_FIELDS = ("slope", "height", "height_fraction", "curvature")


@dataclass(frozen=True)
class ScatterRule:
    """One kind of object and where it stands (see the module docstring).

    Parameters
    ----------
    name
        What the counts and messages call it.
    meshes
        Mesh names (built-in or the user's); each object picks one at random.
    density
        Objects per hectare (10 000 square world units) where the ground suits fully.
    spacing
        Minimum distance to any other object, world units (> 0).
    slope, height, height_fraction, curvature
        Optional :class:`Band` conditions (``height`` and ``height_fraction`` exclude
        each other).
    masks, materials
        ``{name: Band}`` conditions on erosion masks / material layer weights.
    scale
        ``(lo, hi)`` uniform random scale of each object.
    """

    name: str
    meshes: tuple[str, ...]
    density: float
    spacing: float
    slope: Band | None = None
    height: Band | None = None
    height_fraction: Band | None = None
    curvature: Band | None = None
    masks: Mapping[str, Band] = field(default_factory=dict)
    materials: Mapping[str, Band] = field(default_factory=dict)
    scale: tuple[float, float] = (0.8, 1.2)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InvalidParameterError("a scatter rule needs a name")
        what = f"rule {self.name!r}"
        if isinstance(self.meshes, str):
            meshes: tuple = (self.meshes,)
        elif isinstance(self.meshes, Sequence):
            meshes = tuple(self.meshes)
        else:
            meshes = ()
        if not meshes or not all(isinstance(m, str) and m for m in meshes):
            raise InvalidParameterError(f"{what}: meshes must be a non-empty list of mesh names")
        object.__setattr__(self, "meshes", meshes)
        density = _number(self.density, f"{what}: density")
        if not (density >= 0 and math.isfinite(density)):
            raise InvalidParameterError(f"{what}: density must be ≥ 0 objects per hectare, "
                                        f"got {density:g}")
        spacing = _number(self.spacing, f"{what}: spacing")
        if not (spacing > 0 and math.isfinite(spacing)):
            raise InvalidParameterError(f"{what}: spacing must be > 0 world units, got "
                                        f"{spacing:g}")
        object.__setattr__(self, "density", density)
        object.__setattr__(self, "spacing", spacing)
        for name in _BAND_FIELDS:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, Band.parse(value, f"{what}: {name}"))
        if self.height is not None and self.height_fraction is not None:
            raise InvalidParameterError(f"{what}: give height or height_fraction, not both")
        for kind, known in (("masks", MASK_NAMES), ("materials", _material_layers())):
            table = getattr(self, kind)
            if not isinstance(table, Mapping):
                raise InvalidParameterError(f"{what}: {kind} must be a table of name = band")
            for key in table:
                if key not in known:
                    raise InvalidParameterError(
                        f"{what}: unknown {kind[:-1]} {key!r}; expected some of "
                        f"{', '.join(known)}")
            object.__setattr__(self, kind, {k: Band.parse(v, f"{what}: {kind}.{k}")
                                            for k, v in table.items()})
        try:
            lo, hi = (float(v) for v in self.scale)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"{what}: scale must be [min, max], got "
                                        f"{self.scale!r}") from None
        if not (0 < lo <= hi and math.isfinite(hi)):
            raise InvalidParameterError(f"{what}: scale needs 0 < min ≤ max, got [{lo:g}, {hi:g}]")
        object.__setattr__(self, "scale", (lo, hi))

    def as_dict(self) -> dict:
        """The rule as a rules-file table (the inverse of :func:`rule_from_dict`)."""
        out: dict = {"name": self.name, "meshes": list(self.meshes), "density": self.density,
                     "spacing": self.spacing}
        for name in _BAND_FIELDS:
            band = getattr(self, name)
            if band is not None:
                out[name] = band.as_dict()
        for kind in ("masks", "materials"):
            if getattr(self, kind):
                out[kind] = {k: b.as_dict() for k, b in getattr(self, kind).items()}
        out["scale"] = list(self.scale)
        return out


@dataclass(frozen=True)
class RuleSet:
    """Rules in priority order (earlier rules place first and keep their spots), the sea
    level below which nothing stands (``None``: no sea), the object cap, and the user's meshes
    ``{name: ObjectMesh}`` the rules may name besides the built-in ones."""

    rules: tuple[ScatterRule, ...]
    sea_level: float | None = None
    max_objects: int = DEFAULT_MAX_OBJECTS
    meshes: Mapping[str, Any] = field(default_factory=dict)
    #: True for the built-in rules: on a map so large that they would ask for more than
    #: ``max_objects``, every density is lowered by one factor instead of an error.
    adapt_density: bool = False

    def __post_init__(self) -> None:
        rules = tuple(self.rules)
        if not all(isinstance(r, ScatterRule) for r in rules):
            raise InvalidParameterError("rules must be ScatterRule values")
        names = [r.name for r in rules]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise InvalidParameterError(f"two rules are named {dup[0]!r}; names must differ")
        object.__setattr__(self, "rules", rules)
        if self.sea_level is not None:
            sea = _number(self.sea_level, "sea_level")
            if not math.isfinite(sea):
                raise InvalidParameterError("sea_level must be finite")
            object.__setattr__(self, "sea_level", sea)
        if isinstance(self.max_objects, bool) or not isinstance(self.max_objects,
                                                                 (int, np.integer)):
            raise InvalidParameterError(f"max_objects must be a whole number, got "
                                        f"{self.max_objects!r}")
        if self.max_objects < 1:
            raise InvalidParameterError(f"max_objects must be ≥ 1, got {self.max_objects}")
        object.__setattr__(self, "max_objects", int(self.max_objects))


def _material_layers() -> tuple[str, ...]:
    from terrascape.texture.photo_materials import MATERIAL_LAYERS

    return MATERIAL_LAYERS


_RULE_KEYS = tuple(f.name for f in fields(ScatterRule))
_RULESET_KEYS = ("rules", "sea_level", "max_objects", "meshes")


def rule_from_dict(table: Mapping[str, Any], index: int = 0) -> ScatterRule:
    """A rule from a rules-file table; an unknown key is an error naming it."""
    if not isinstance(table, Mapping):
        raise InvalidParameterError(f"rule {index + 1} must be a table, got {table!r}")
    label = repr(table["name"]) if isinstance(table.get("name"), str) else str(index + 1)
    unknown = sorted(set(table) - set(_RULE_KEYS))
    if unknown:
        raise InvalidParameterError(
            f"rule {label}: unknown key {unknown[0]!r}; a rule takes {', '.join(_RULE_KEYS)}")
    missing = [k for k in ("name", "meshes", "density", "spacing") if k not in table]
    if missing:
        raise InvalidParameterError(f"rule {label}: missing key {missing[0]!r}")
    return ScatterRule(**dict(table))


def ruleset_from_dict(data: Mapping[str, Any], *, meshes: Mapping[str, Any] | None = None
                      ) -> RuleSet:
    """A :class:`RuleSet` from a parsed rules file (``meshes``: the user's meshes already
    loaded from the file's ``[meshes]`` table)."""
    if not isinstance(data, Mapping):
        raise InvalidParameterError("a rules file must hold a table at its top level")
    unknown = sorted(set(data) - set(_RULESET_KEYS))
    if unknown:
        raise InvalidParameterError(
            f"unknown key {unknown[0]!r} in the rules file; it takes {', '.join(_RULESET_KEYS)}")
    rules = data.get("rules")
    if not isinstance(rules, Sequence) or isinstance(rules, str) or not rules:
        raise InvalidParameterError("a rules file needs at least one [[rules]] table")
    kwargs: dict = {"rules": tuple(rule_from_dict(t, i) for i, t in enumerate(rules)),
                    "meshes": dict(meshes or {})}
    if "sea_level" in data:
        kwargs["sea_level"] = data["sea_level"]
    if "max_objects" in data:
        kwargs["max_objects"] = data["max_objects"]
    return RuleSet(**kwargs)


def default_tree_rule(meshes: Sequence[str] = ("conifer", "broadleaf")) -> ScatterRule:
    """The default rule for trees (the one a user's own glTF model is scattered by)."""
    return ScatterRule("trees", tuple(meshes), density=60.0, spacing=5.0,
                       slope=Band(0.0, 32.0, 6.0), height_fraction=Band(-math.inf, 0.82, 0.05),
                       materials={"snow": Band(0.0, 0.2, 0.2), "water": Band(0.0, 0.05, 0.1)},
                       scale=(0.75, 1.25))


def default_rules(*, masks: Sequence[str] = (), sea_level: float | None = None,
                  max_objects: int = DEFAULT_MAX_OBJECTS) -> RuleSet:
    """The built-in rules.

    In priority order: a few large buildings and houses on flat low ground; boulders and
    rocks on steep ground (and on worn ground when the ``wear`` mask is given); conifers high
    and on steep-ish slopes up to the tree line; broadleaf trees low and on gentle slopes;
    bushes in between. No snow, water or (with ``sea_level``) sea under any of them.
    """
    dry = {"snow": Band(0.0, 0.2, 0.2), "water": Band(0.0, 0.05, 0.1)}
    rules = [
        ScatterRule("halls", ("hall",), density=0.03, spacing=60.0, slope=Band(0.0, 4.0, 3.0),
                    height_fraction=Band(-math.inf, 0.3, 0.1), materials=dry,
                    scale=(0.9, 1.1)),
        ScatterRule("houses", ("house",), density=0.25, spacing=25.0,
                    slope=Band(0.0, 7.0, 4.0), height_fraction=Band(-math.inf, 0.4, 0.1),
                    materials=dry, scale=(0.9, 1.15)),
        ScatterRule("boulders", ("boulder",), density=3.0, spacing=8.0,
                    slope=Band(30.0, 90.0, 8.0), materials={"water": Band(0.0, 0.05, 0.1)},
                    scale=(0.7, 1.4)),
        ScatterRule("rocks", ("rock",), density=10.0, spacing=3.0, slope=Band(24.0, 90.0, 8.0),
                    materials={"water": Band(0.0, 0.05, 0.1)}, scale=(0.6, 1.5)),
    ]
    if "wear" in masks:
        rules.append(ScatterRule("scree rocks", ("rock",), density=20.0, spacing=2.5,
                                 masks={"wear": Band(0.3, 1.0, 0.2)},
                                 materials={"water": Band(0.0, 0.05, 0.1)}, scale=(0.5, 1.1)))
    rules += [
        ScatterRule("conifers", ("conifer",), density=70.0, spacing=5.0,
                    slope=Band(0.0, 36.0, 6.0),
                    height_fraction=Band(0.42, 0.82, 0.12), materials=dry, scale=(0.7, 1.3)),
        ScatterRule("broadleaf trees", ("broadleaf",), density=40.0, spacing=7.0,
                    slope=Band(0.0, 22.0, 6.0), height_fraction=Band(-math.inf, 0.45, 0.12),
                    materials=dry, scale=(0.75, 1.25)),
        ScatterRule("bushes", ("bush",), density=25.0, spacing=3.0, slope=Band(0.0, 26.0, 5.0),
                    height_fraction=Band(-math.inf, 0.75, 0.1), materials=dry,
                    scale=(0.6, 1.4)),
    ]
    return RuleSet(tuple(rules), sea_level=sea_level, max_objects=max_objects,
                   adapt_density=True)


# --- the ground each rule reads -----------------------------------------------------------------
class GroundFields:
    """Slope, heights, curvature, masks and material weights of one map, computed on demand."""

    def __init__(self, heightmap: Heightmap, masks: Mapping[str, Any] | None, seed: int) -> None:
        from terrascape.texture.terrain_material import check_masks

        self.hm = heightmap
        self.raw_masks = check_masks(heightmap.shape, dict(masks or {}))
        self.seed = seed
        self._cache: dict[str, np.ndarray] = {}

    def _get(self, key: str, make) -> np.ndarray:
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    @property
    def heights(self) -> np.ndarray:
        return self._get("heights", lambda: self.hm.heights.astype(np.float64))

    height = heights  # the name a rule's ``height`` band reads

    @property
    def slope(self) -> np.ndarray:
        return self._get("slope", lambda: np.degrees(self.hm.slope().astype(np.float64)))

    @property
    def height_fraction(self) -> np.ndarray:
        def make():
            h = self.heights
            lo, hi = float(h.min()), float(h.max())
            return (h - lo) / (hi - lo) if hi > lo else np.zeros_like(h)

        return self._get("height_fraction", make)

    @property
    def curvature(self) -> np.ndarray:
        def make():
            # the terrain material's curvature (texture/terrain_material.py), same scaling
            dx, dz = self.hm.spacing
            lap = ndimage.laplace(ndimage.gaussian_filter(self.heights, 1.0, mode="nearest"),
                                  mode="nearest") / (dx * dz)
            return np.clip(lap / max(float(np.percentile(np.abs(lap), 90.0)), 1e-12), -1.0, 1.0)

        return self._get("curvature", make)

    def mask(self, name: str, rule: str) -> np.ndarray:
        if name not in self.raw_masks:
            raise InvalidParameterError(
                f"rule {rule!r} reads the {name} mask, which was not given (write the masks "
                "with `terrascape erode --masks FOLDER` and pass them)")

        def make():
            m = self.raw_masks[name].astype(np.float64)
            if name in ("flow", "deposition"):  # as the terrain material scales them
                m = ndimage.gaussian_filter(m, 1.0, mode="nearest")
                pos = m[m > 0]
                if pos.size == 0:
                    return np.zeros_like(m)
                m = m / max(float(np.percentile(pos, 95.0)), 1e-12)
            return np.clip(m, 0.0, 1.0)

        return self._get(f"mask:{name}", make)

    def material(self, name: str) -> np.ndarray:
        def make():
            from terrascape.texture.terrain_material import material_weights

            return material_weights(self.hm, masks=self.raw_masks or None,
                                    seed=self.seed).astype(np.float64)

        weights = self._get("materials", make)
        return weights[_material_layers().index(name)]


def ground_fields(heightmap: Heightmap, masks: Mapping[str, Any] | None = None, *,
                  seed: int = 0) -> GroundFields:
    """The lazily computed ground a set of rules reads (masks validated here)."""
    return GroundFields(heightmap, masks, seed)


def suitability(rule: ScatterRule, ground: GroundFields,
                sea_level: float | None = None) -> np.ndarray:
    """float64 ``(rows, cols)`` in [0, 1]: how well each sample suits ``rule``."""
    w = np.ones(ground.hm.shape, np.float64)
    for name in _BAND_FIELDS:
        band = getattr(rule, name)
        if band is not None:
            w *= band.weight(getattr(ground, name))
    for name, band in rule.masks.items():
        w *= band.weight(ground.mask(name, rule.name))
    for name, band in rule.materials.items():
        w *= band.weight(ground.material(name))
    if sea_level is not None:
        w[ground.heights < sea_level] = 0.0
    return w
