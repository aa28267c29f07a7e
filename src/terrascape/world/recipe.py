"""World recipes: what a world is built from, read from a small TOML or JSON file.

A recipe names the generator (``fbm`` or ``ridged`` with its registry parameters), the size,
sample spacing, seed and chunk size, and the steps that follow: thermal erosion, normals and
the shadow mask. Its canonical JSON (sorted keys, every default filled in) is stored in the
world and hashed, so a world is never continued with another recipe.

Example (TOML)::

    size = [8193, 8193]
    spacing = 2.0
    seed = 7
    chunk = 1024

    [generator]
    name = "fbm"        # or "ridged"
    relief = 600.0      # heights are relief · the generator's raw value (fbm: [-1, 1])
    scale = 1024        # any generator parameter of the registry
    octaves = 9

    [erosion]           # hydraulic erosion before the thermal step (optional)
    model = "grid"      # virtual pipes (exact with its halo) or "droplets" (seam measured)
    iterations = 100

    [thermal]
    iterations = 8
    talus = 35.0

    [normals]
    height_scale = 1.0

    [shadow]
    azimuth = 90.0
    elevation = 25.0
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.generate.registry import get_generator, resolve_params

#: Generators whose samples depend only on their absolute position (tileable with ``origin``).
TILEABLE_GENERATORS = ("fbm", "ridged")
DEFAULT_CHUNK = 1024
#: A world's side may be up to 2**40 samples (the noise's origin range).
MAX_SIDE = 1 << 40

_TOP_KEYS = {"size", "spacing", "seed", "chunk", "generator", "erosion", "thermal", "normals",
             "shadow"}
#: Erosion models that tile (``model`` of ``[erosion]``), their keys and defaults (the
#: in-memory functions' own defaults, except the grid's 300 iterations, whose halo of 900
#: samples would need chunks of 900 or more).
EROSION_MODELS: dict[str, dict[str, Any]] = {
    "grid": {"iterations": 100, "rain": 0.01, "capacity": 0.05, "min_tilt": 0.02,
             "max_depth": 0.5, "dissolving": 0.3, "deposition": 0.3, "evaporation": 0.01},
    "droplets": {"density": 1.0, "inertia": 0.05, "capacity": 4.0, "min_slope": 0.01,
                 "erosion": 0.3, "deposition": 0.3, "evaporation": 0.01, "gravity": 4.0,
                 "max_steps": 30, "radius": 3.0},
}
_INTEGER_EROSION_KEYS = {"iterations", "max_steps"}
_THERMAL_KEYS = {"iterations", "talus", "rate"}
_NORMALS_KEYS = {"height_scale"}
_SHADOW_KEYS = {"azimuth", "elevation"}


@dataclass(frozen=True)
class Recipe:
    """A checked world recipe (every default resolved)."""

    rows: int
    cols: int
    spacing: float
    seed: int
    chunk: int
    generator: str
    relief: float
    params: dict[str, Any] = field(default_factory=dict)
    thermal: dict[str, Any] | None = None
    normals: dict[str, Any] | None = None
    shadow: dict[str, Any] | None = None
    erosion: dict[str, Any] | None = None

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "size": [self.rows, self.cols], "spacing": self.spacing, "seed": self.seed,
            "chunk": self.chunk,
            "generator": {"name": self.generator, "relief": self.relief, **self.params},
        }
        for key in ("erosion", "thermal", "normals", "shadow"):
            value = getattr(self, key)
            if value is not None:
                out[key] = dict(value)
        return out

    def canonical_json(self) -> str:
        """Sorted, compact JSON of the resolved recipe: the same world gives the same text."""
        return json.dumps(self.to_dict(), sort_keys=True, separators=(",", ":"))

    def digest(self) -> str:
        """SHA-256 of :meth:`canonical_json` (stored in the world; never mix two recipes)."""
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()


def _unknown(keys, known: set[str], where: str) -> None:
    extra = sorted(set(keys) - known)
    if extra:
        raise InvalidParameterError(
            f"unknown recipe key {where}{extra[0]!r} (known: {', '.join(sorted(known))})")


def _number(value: Any, key: str, *, lo: float | None = None, hi: float | None = None,
            open_lo: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InvalidParameterError(f"recipe key {key!r} must be a finite number, got {value!r}")
    v = float(value)
    if lo is not None and (v < lo or (open_lo and v == lo)):
        raise InvalidParameterError(
            f"recipe key {key!r} must be {'>' if open_lo else '≥'} {lo:g}, got {v:g}")
    if hi is not None and v > hi:
        raise InvalidParameterError(f"recipe key {key!r} must be ≤ {hi:g}, got {v:g}")
    return v


def _integer(value: Any, key: str, *, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InvalidParameterError(f"recipe key {key!r} must be a whole number, got {value!r}")
    if not lo <= value <= hi:
        raise InvalidParameterError(f"recipe key {key!r} must be in [{lo}, {hi}], got {value}")
    return int(value)


def _table(data: dict, key: str) -> dict | None:
    value = data.get(key)
    if value is None or value is False:  # `normals = false`: the step is off
        return None
    if value is True:
        return {}
    if not isinstance(value, dict):
        raise InvalidParameterError(f"recipe key {key!r} must be a table, got {value!r}")
    return value


def recipe_from_dict(data: dict[str, Any]) -> Recipe:
    """Check a recipe given as a dict (the parsed TOML/JSON) and fill in its defaults."""
    if not isinstance(data, dict):
        raise InvalidParameterError("a world recipe must be a table of keys")
    _unknown(data, _TOP_KEYS, "")
    if "size" not in data:
        raise InvalidParameterError("recipe key 'size' is missing: give [rows, cols] or N")
    size = data["size"]
    if isinstance(size, int) and not isinstance(size, bool):
        size = [size, size]
    if not isinstance(size, list | tuple) or len(size) != 2:
        raise InvalidParameterError(f"recipe key 'size' must be [rows, cols], got {size!r}")
    rows = _integer(size[0], "size", lo=3, hi=MAX_SIDE)
    cols = _integer(size[1], "size", lo=3, hi=MAX_SIDE)
    spacing = _number(data.get("spacing", 1.0), "spacing", lo=0.0, open_lo=True)
    seed = _integer(data.get("seed", 0), "seed", lo=0, hi=(1 << 63) - 1)
    chunk = _integer(data.get("chunk", DEFAULT_CHUNK), "chunk", lo=16, hi=1 << 15)

    gen_table = _table(data, "generator")
    if gen_table is None:
        raise InvalidParameterError("recipe key 'generator' is missing: give [generator] name")
    gen_table = dict(gen_table)
    name = gen_table.pop("name", None)
    if name not in TILEABLE_GENERATORS:
        raise InvalidParameterError(
            f"recipe key 'generator.name' must be one of {', '.join(TILEABLE_GENERATORS)} "
            f"(the generators that tile exactly), got {name!r}")
    relief = _number(gen_table.pop("relief", 0.2 * max(rows - 1, cols - 1) * spacing),
                     "generator.relief", lo=0.0, open_lo=True)
    gen = get_generator(name)
    # "relief" sets the height scale of a world (amplitude × raw noise), so the registry's
    # own amplitude parameter is not a recipe key: one way to give the heights.
    known = {p.name for p in gen.params} - {"amplitude"}
    _unknown(gen_table, known | {"name", "relief"}, "generator.")
    params = resolve_params(gen, (rows, cols), gen_table)
    params.pop("amplitude", None)

    thermal = _table(data, "thermal")
    if thermal is not None:
        _unknown(thermal, _THERMAL_KEYS, "thermal.")
        thermal = {
            "iterations": _integer(thermal.get("iterations", 10), "thermal.iterations",
                                   lo=0, hi=4096),
            "talus": _number(thermal.get("talus", 30.0), "thermal.talus", lo=0.0, hi=89.0),
            "rate": _number(thermal.get("rate", 0.5), "thermal.rate", lo=0.0, hi=0.5,
                            open_lo=True),
        }
        if 2 * thermal["iterations"] > chunk:
            raise InvalidParameterError(
                f"recipe key 'thermal.iterations' = {thermal['iterations']} needs a halo of "
                f"{2 * thermal['iterations']} samples, more than the chunk ({chunk}): use a "
                "bigger chunk or fewer iterations")
    erosion = _erosion(_table(data, "erosion"), chunk)
    normals = _table(data, "normals")
    if normals is not None:
        _unknown(normals, _NORMALS_KEYS, "normals.")
        normals = {"height_scale": _number(normals.get("height_scale", 1.0),
                                           "normals.height_scale")}
    shadow = _table(data, "shadow")
    if shadow is not None:
        _unknown(shadow, _SHADOW_KEYS, "shadow.")
        shadow = {
            "azimuth": _number(shadow.get("azimuth", 135.0), "shadow.azimuth") % 360.0,
            "elevation": _number(shadow.get("elevation", 30.0), "shadow.elevation", lo=0.0,
                                 hi=90.0, open_lo=True),
        }
    return Recipe(rows, cols, spacing, seed, chunk, name, relief,
                  {k: (list(v) if isinstance(v, tuple) else v) for k, v in params.items()},
                  thermal, normals, shadow, erosion)


def erosion_halo(erosion: dict[str, Any]) -> int:
    """Samples each side of a chunk its erosion reads (grid: 3 per iteration, exact;
    droplets: a droplet's longest path, its brush and the bilinear corner)."""
    if erosion["model"] == "grid":
        from terrascape.filters.virtual_pipe_erosion import HALO_PER_ITERATION

        return HALO_PER_ITERATION * erosion["iterations"]
    return erosion["max_steps"] + math.ceil(erosion["radius"]) + 2


def _erosion(table: dict | None, chunk: int) -> dict[str, Any] | None:
    if table is None:
        return None
    model = table.get("model")
    if model in ("stream-power", "stream_power", "river"):
        raise InvalidParameterError(
            "recipe key 'erosion.model' = 'stream-power' does not tile: its drainage area and "
            "base level come from the whole map (a river crosses any number of chunks), so a "
            "world offers grid and droplets; erode a map that fits in memory with "
            "`terrascape erode`")
    if model not in EROSION_MODELS:
        raise InvalidParameterError(
            f"recipe key 'erosion.model' must be one of {', '.join(EROSION_MODELS)} (the "
            f"models that tile), got {model!r}")
    defaults = EROSION_MODELS[model]
    _unknown(table, set(defaults) | {"model"}, "erosion.")
    out: dict[str, Any] = {"model": model}
    for key, default in defaults.items():
        value = table.get(key, default)
        where = f"erosion.{key}"
        if key in _INTEGER_EROSION_KEYS:
            out[key] = _integer(value, where, lo=1 if key == "max_steps" else 0, hi=100_000)
        elif key in ("rain", "capacity", "min_slope", "gravity", "max_depth", "evaporation"):
            out[key] = _number(value, where, lo=0.0, open_lo=key == "max_depth")
        elif key == "density":
            out[key] = _number(value, where, lo=0.0, hi=64.0)
        elif key == "radius":
            out[key] = _number(value, where, lo=0.0, hi=16.0)
        else:  # shares
            out[key] = _number(value, where, lo=0.0, hi=1.0)
    halo = erosion_halo(out)
    # Droplets run in four phases whose windows must not overlap: halo ≤ half a chunk.
    if (2 * halo if model == "droplets" else halo) > chunk:
        raise InvalidParameterError(
            f"recipe [erosion] ({model}) needs a halo of {halo} samples, more than "
            f"{'half ' if model == 'droplets' else ''}the chunk ({chunk}): use a bigger "
            f"chunk or fewer {'iterations' if model == 'grid' else 'max_steps'}")
    return out


def load_recipe(path: str | Path) -> Recipe:
    """Read a recipe from a ``.toml`` or ``.json`` file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise FileFormatError(f"cannot read recipe {p}: {exc.strerror or exc}") from None
    try:
        data = json.loads(text) if p.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise FileFormatError(f"recipe {p.name} is not valid "
                              f"{'JSON' if p.suffix.lower() == '.json' else 'TOML'}: {exc}"
                              ) from None
    return recipe_from_dict(data)


__all__ = ["DEFAULT_CHUNK", "EROSION_MODELS", "TILEABLE_GENERATORS", "Recipe", "erosion_halo",
           "load_recipe", "recipe_from_dict"]
