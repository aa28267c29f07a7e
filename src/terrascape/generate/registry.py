"""The generator registry: every heightmap generator by name, with typed parameters.

One table serves the library, ``terrascape generate NAME`` (one sub-command per entry, its
options built from the parameters), ``render --generate NAME``, ``view --generate NAME``,
the demo and the benchmarks, so a name and a seed give the same terrain everywhere.

Defaults are chosen to look like landscape at any size:

* **relief** — heights are mapped to ``[0, relief]`` world units, and the default relief is
  :data:`DEFAULT_RELIEF_FRACTION` (20 %) of the map's larger horizontal extent
  (``(side - 1) · spacing``): a 513-sample map on a 2 m grid is 1024 m across and up to
  204.8 m high. ``raw=True`` keeps the generator's own heights instead;
* diamond-square uses the square-square variant (no spike at the centre, no creases on
  the coarse lattice lines); ``variant="classic"`` is the thesis's exact algorithm;
* sizes in samples (fault width, hill radii, noise wavelength) scale with the map, so a
  257² and a 2049² map of the same generator look alike.

A new generator is one module plus one :class:`Generator` entry in :data:`GENERATORS`.

Example
-------
>>> from terrascape.generate.registry import generate, get_generator
>>> hm = generate("fbm", 257, seed=3, spacing=2.0)            # defaults: relief 102.4 m
>>> hm = generate("diamond-square", 513, seed=7, variant="classic", decay="hurst")
>>> [p.name for p in get_generator("hills").params]
['count', 'radius_min', 'radius_max', 'height', 'floor']
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from terrascape._validate import check_positive
from terrascape.errors import InvalidParameterError
from terrascape.generate._common import grid_shape, spacing_pair
from terrascape.heightmap import Heightmap, normalise_into

DEFAULT_RELIEF_FRACTION = 0.2
#: Mean number of hills over each sample for the default hills (no flat floor): the share
#: of samples no hill reaches is ``exp(-coverage)`` (Poisson), 4.5e-5 at 10.
HILL_COVERAGE = 10.0
#: With ``floor=True``: the thesis's sparse hills on a plain (``exp(-1.5)`` ≈ 22 % flat).
HILL_COVERAGE_FLOOR = 1.5

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Param:
    """One generator parameter: keyword ``name``, type, default (``None``: computed from the
    map, described by ``auto``), help text, and the allowed ``choices`` of a string."""

    name: str
    type: type
    default: object
    help: str
    choices: tuple[str, ...] = ()
    auto: str = ""
    count: int = 1  # > 1: a tuple of that many floats (CLI: comma-separated)

    @property
    def option(self) -> str:
        """The command-line spelling, ``--decay-step`` for ``decay_step``."""
        return "--" + self.name.replace("_", "-")

    def check(self, value: object) -> object:
        """``value`` converted to the parameter's type, or a one-line error."""
        if value is None:
            return None
        if self.count > 1:
            vals = tuple(value) if not np.isscalar(value) else (value,) * self.count
            if len(vals) != self.count:
                raise InvalidParameterError(
                    f"{self.option} needs {self.count} numbers, got {value!r}")
            return tuple(float(v) for v in vals)
        if self.type is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise InvalidParameterError(f"{self.option} must be true or false, got {value!r}")
            return bool(value)
        try:
            out = self.type(value)
        except (TypeError, ValueError):
            raise InvalidParameterError(
                f"{self.option} must be {self.type.__name__}, got {value!r}") from None
        if self.choices and out not in self.choices:
            raise InvalidParameterError(
                f"{self.option} must be one of {', '.join(self.choices)}, got {value!r}")
        return out

    def parse(self, text: str) -> object:
        """Parse a command-line string (``--gen-param name=TEXT``)."""
        if self.count > 1:
            from terrascape.cli.parsing import parse_floats

            return parse_floats(text, self.count, name=self.option)
        if self.type is bool:
            low = text.strip().lower()
            if low not in ("1", "0", "true", "false", "yes", "no", "on", "off"):
                raise InvalidParameterError(f"{self.option} must be true or false, got {text!r}")
            return low in ("1", "true", "yes", "on")
        return self.check(text)


@dataclass(frozen=True)
class Generator:
    """A registered generator.

    ``build(shape, seed=, spacing=, progress=, **params)`` returns the raw heightmap; the
    params it receives are already checked and have their automatic defaults resolved by
    ``resolve(shape, params)``."""

    name: str
    summary: str
    build: Callable[..., Heightmap]
    params: tuple[Param, ...]
    resolve: Callable[[tuple[int, int], dict], dict] = field(default=lambda shape, p: p)
    square_pow2: bool = False
    progress_total: Callable[[dict], int] | None = None
    aliases: tuple[str, ...] = ()

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        known = ", ".join(p.name for p in self.params)
        raise InvalidParameterError(
            f"generator {self.name} has no parameter {name!r} (it has: {known})")

    def defaults(self) -> dict[str, object]:
        return {p.name: p.default for p in self.params}


# --- the entries ---------------------------------------------------------------------------------


def _build_diamond_square(shape, *, seed, spacing, progress, variant, roughness, decay,
                          decay_step, hurst, corners, integer):
    from terrascape.generate.diamond_square import diamond_square
    from terrascape.generate.square_square import square_square

    if variant == "classic":
        return diamond_square(shape[0], roughness=roughness, decay=decay,
                              decay_step=decay_step, hurst=hurst, seed=seed, spacing=spacing,
                              corners=corners, integer=integer)
    if integer or corners is not None:
        raise InvalidParameterError(
            "--integer and --corners belong to the thesis's algorithm: add --variant classic")
    return square_square(shape[0], roughness=roughness, decay=decay, decay_step=decay_step,
                         hurst=hurst, seed=seed, spacing=spacing)


def _resolve_diamond_square(shape, p):
    if p["variant"] is None:
        p["variant"] = "classic" if p["integer"] else "square-square"
    return p


def _fault_width(shape: tuple[int, int]) -> float:
    return max(2.0, 24.0 * min(shape) / 513.0)


def _build_fault(shape, *, seed, spacing, progress, iterations, start_displacement,
                 end_displacement, falloff, width):
    from terrascape.generate.fault import fault_formation

    return fault_formation(shape, iterations=iterations, start_displacement=start_displacement,
                           end_displacement=end_displacement, falloff=falloff, width=width,
                           seed=seed, spacing=spacing, progress=progress)


def _resolve_fault(shape, p):
    if p["width"] is None:
        p["width"] = _fault_width(shape)
    return p


def _resolve_hills(shape, p):
    # Twice the library's side/64 … side/16: with every sample under ~10 hills, smaller
    # hills pile up into needles at a relief of 20 % of the extent.
    m = min(shape)
    lo, hi = max(1.0, m / 32.0), max(2.0, m / 8.0)
    p["radius_min"] = lo if p["radius_min"] is None else p["radius_min"]
    p["radius_max"] = hi if p["radius_max"] is None else p["radius_max"]
    if p["count"] is None:
        a, b = p["radius_min"], p["radius_max"]
        margin = 0.0 if p["floor"] else b
        area = (shape[0] + 2 * margin) * (shape[1] + 2 * margin)
        mean_disc = math.pi * (a * a + a * b + b * b) / 3.0  # E[π r²], r uniform in [a, b]
        coverage = HILL_COVERAGE_FLOOR if p["floor"] else HILL_COVERAGE
        p["count"] = max(1, math.ceil(coverage * area / max(mean_disc, 1e-9)))
    return p


def _build_hills(shape, *, seed, spacing, progress, count, radius_min, radius_max, height,
                 floor):
    from terrascape.generate.hills import hills

    # Without a floor the centres also fall up to one radius outside the map, so the border
    # is covered as densely as the middle.
    return hills(shape, count=count, radius_range=(radius_min, radius_max), height=height,
                 seed=seed, spacing=spacing, progress=progress,
                 margin=0.0 if floor else radius_max)


def _resolve_noise(shape, p):
    if p["scale"] is None:
        p["scale"] = max(min(shape) - 1, 1) / 4.0
    if p["octaves"] is None:
        # Down to a finest wavelength of about 4 samples.
        p["octaves"] = int(min(max(round(math.log2(max(p["scale"], 1.0) / 4.0)) + 1, 1), 24))
    return p


def _build_fbm(shape, *, seed, spacing, progress, scale, octaves, lacunarity, gain, amplitude):
    from terrascape.generate.noise import fbm

    return fbm(shape, scale=scale, octaves=octaves, lacunarity=lacunarity, gain=gain,
               amplitude=amplitude, seed=seed, spacing=spacing)


def _build_ridged(shape, *, seed, spacing, progress, scale, octaves, lacunarity, gain,
                  amplitude, offset):
    from terrascape.generate.noise import ridged

    return ridged(shape, scale=scale, octaves=octaves, lacunarity=lacunarity, gain=gain,
                  amplitude=amplitude, offset=offset, seed=seed, spacing=spacing)


_DECAY_LAWS = ("linear", "halve", "sqrt", "hurst")
_NOISE_PARAMS = (
    Param("scale", float, None, "Wavelength of the first octave (samples).", auto="side/4"),
    Param("octaves", int, None, "Number of octaves (1–24).",
          auto="down to a 4-sample wavelength"),
    Param("lacunarity", float, 2.0, "Frequency ratio between octaves (1–16)."),
    Param("gain", float, 0.5, "Amplitude ratio between octaves (0–1)."),
    Param("amplitude", float, 1.0, "Height amplitude (world units; with --raw)."),
)

GENERATORS: dict[str, Generator] = {
    g.name: g
    for g in (
        Generator(
            name="diamond-square",
            summary="Diamond-square fractal terrain on a (2**n + 1)² grid; the default "
            "square-square variant (Miller 1986) has no centre spike or lattice creases.",
            build=_build_diamond_square,
            resolve=_resolve_diamond_square,
            square_pow2=True,
            aliases=("diamond_square",),
            params=(
                Param("variant", str, None,
                      "square-square (Miller 1986: no centre spike, no creases on the coarse "
                      "lattice) or classic (the thesis's diamond-square, exactly).",
                      choices=("square-square", "classic"),
                      auto="square-square; classic with --integer"),
                Param("roughness", float, 1.0,
                      "Offset amplitude of the first level (world units; with --raw)."),
                Param("decay", str, "halve", "Roughness decay per level.",
                      choices=_DECAY_LAWS),
                Param("decay_step", float, None, "Decrement of the linear law (world units).",
                      auto="roughness / levels"),
                Param("hurst", float, 0.8, "Hurst exponent H in [0, 1] (decay hurst)."),
                Param("corners", float, None,
                      "Fixed corner heights TL,TR,BL,BR (world units; classic only).",
                      auto="random", count=4),
                Param("integer", bool, False,
                      "The thesis's integer arithmetic (classic; integer roughness/step)."),
            ),
        ),
        Generator(
            name="fault",
            summary="Fault-formation terrain: random lines raise one side and lower the "
            "other.",
            build=_build_fault,
            resolve=_resolve_fault,
            progress_total=lambda p: p["iterations"],
            aliases=("fault_formation", "fault-formation"),
            params=(
                Param("iterations", int, 400, "Number of fault lines."),
                Param("start_displacement", float, 1.0,
                      "Displacement of the first fault (world units)."),
                Param("end_displacement", float, 0.1,
                      "Displacement of the last fault (linear in between)."),
                Param("falloff", str, "cosine",
                      "Profile across the line: step (the thesis's cliff), sine (a smooth "
                      "step), cosine (a ridge or trench).", choices=("step", "sine", "cosine")),
                Param("width", float, None,
                      "Transition width across the line (samples; sine/cosine).",
                      auto="24 · side / 513, at least 2"),
            ),
        ),
        Generator(
            name="hills",
            summary="Cosine-hills terrain: h += d/2 + cos(pd·π)·d/2 inside each circle.",
            build=_build_hills,
            resolve=_resolve_hills,
            progress_total=lambda p: p["count"],
            params=(
                Param("count", int, None, "Number of hills.",
                      auto="every sample under ~10 hills (1.5 with --floor)"),
                Param("radius_min", float, None, "Smallest hill radius (samples).",
                      auto="side/32"),
                Param("radius_max", float, None, "Largest hill radius (samples).",
                      auto="side/8"),
                Param("height", float, 1.0,
                      "Hill height, the thesis's 'odmak' (world units; with --raw)."),
                Param("floor", bool, False,
                      "Sparse hills on a flat plain (the thesis's look); default: hills "
                      "everywhere, no flat floor."),
            ),
        ),
        Generator(
            name="fbm",
            summary="Gradient-noise fBm terrain (a sum of octaves of tileable noise).",
            build=_build_fbm,
            resolve=_resolve_noise,
            params=_NOISE_PARAMS,
        ),
        Generator(
            name="ridged",
            summary="Ridged multifractal terrain (Musgrave): sharp ridges, smooth valleys.",
            build=_build_ridged,
            resolve=_resolve_noise,
            params=(*_NOISE_PARAMS,
                    Param("offset", float, 1.0, "Ridge offset (0.5–2).")),
        ),
    )
}

_ALIASES = {alias: g.name for g in GENERATORS.values() for alias in g.aliases}


def generator_names() -> tuple[str, ...]:
    """The registered names, in registry order (``diamond-square``, ``fault``, …)."""
    return tuple(GENERATORS)


def names_help() -> str:
    """``"diamond-square, fault, hills, fbm or ridged"`` for help texts."""
    names = generator_names()
    return ", ".join(names[:-1]) + " or " + names[-1]


def get_generator(name: str) -> Generator:
    """The entry for ``name``; an old spelling (``diamond_square``) works with a
    DeprecationWarning; anything else is an :class:`InvalidParameterError` listing the names."""
    if name in GENERATORS:
        return GENERATORS[name]
    if name in _ALIASES:
        warnings.warn(f"generator name {name!r} is deprecated; use {_ALIASES[name]!r}",
                      DeprecationWarning, stacklevel=2)
        return GENERATORS[_ALIASES[name]]
    raise InvalidParameterError(
        f"--generate must be one of {', '.join(generator_names())}, got {name!r}")


def default_relief(shape: tuple[int, int], spacing: float | Sequence[float]) -> float:
    """20 % of the larger horizontal extent, ``max((cols-1)·dx, (rows-1)·dz)``."""
    dx, dz = spacing_pair(spacing)
    return DEFAULT_RELIEF_FRACTION * max((shape[1] - 1) * float(dx), (shape[0] - 1) * float(dz))


def resolve_params(gen: Generator, shape: tuple[int, int], params: dict) -> dict:
    """Checked parameters with every default filled in (automatic ones from ``shape``)."""
    unknown = set(params) - {p.name for p in gen.params}
    if unknown:
        gen.param(sorted(unknown)[0])  # raises, listing the known ones
    values = gen.defaults()
    for key, value in params.items():
        values[key] = gen.param(key).check(value)
    return gen.resolve(shape, values)


def generate(
    name: str,
    size_or_shape: int | Sequence[int],
    *,
    seed: int | np.random.Generator | None = 0,
    spacing: float | Sequence[float] = 1.0,
    relief: float | None = None,
    raw: bool = False,
    progress: Progress | None = None,
    **params: object,
) -> Heightmap:
    """Generate a heightmap with the registered generator ``name``.

    Parameters
    ----------
    name
        A registered name (:func:`generator_names`).
    size_or_shape
        ``N`` or ``(rows, cols)``; diamond-square needs a square ``2**n + 1``.
    seed, spacing
        As for every generator: the same seed gives the same bytes.
    relief
        Heights are mapped to ``[0, relief]`` world units; default :func:`default_relief`
        (20 % of the map's extent).
    raw
        Keep the generator's own heights (``relief`` must then be ``None``).
    progress
        ``progress(done, total)`` for the chunked generators (fault, hills).
    **params
        The generator's parameters (:attr:`Generator.params`); omitted ones take their
        defaults.

    Returns
    -------
    Heightmap
        float32 heights; ``metadata["generator_params"]`` holds the resolved parameters.
    """
    gen = get_generator(name)
    shape = grid_shape(size_or_shape, algorithm=gen.name)
    if gen.square_pow2:
        from terrascape._validate import check_size_pow2_plus1

        if shape[0] != shape[1]:
            raise InvalidParameterError(
                f"{gen.name} needs a square size N = 2**n + 1, got {shape[1]}x{shape[0]}")
        check_size_pow2_plus1(shape[0], algorithm=gen.name)
    values = resolve_params(gen, shape, params)
    if raw and relief is not None:
        raise InvalidParameterError("give either a relief (height scale) or raw heights, "
                                    "not both")
    hm = gen.build(shape, seed=seed, spacing=spacing, progress=progress, **values)
    top = None if raw else (default_relief(shape, hm.spacing) if relief is None
                            else check_positive(relief, "relief (height scale)"))
    meta = dict(hm.metadata)
    meta["generator_params"] = {k: (list(v) if isinstance(v, tuple) else v)
                                for k, v in values.items()}
    heights = hm.heights
    if top is not None:
        if heights.flags.owndata:  # the generator's new array: map it in place
            heights.flags.writeable = True
            normalise_into(heights, heights, 0.0, top)
        else:
            heights = hm.normalised(0.0, top).heights
    return Heightmap(heights, hm.spacing, meta)


def parse_params(name: str, texts: Sequence[str] | None) -> dict[str, object]:
    """``["octaves=8", "gain=0.6"]`` (``--gen-param`` on the command line) → checked params."""
    gen = get_generator(name)
    out: dict[str, object] = {}
    for text in texts or ():
        key, sep, value = text.partition("=")
        if not sep:
            raise InvalidParameterError(f"--gen-param needs NAME=VALUE, got {text!r}")
        param = gen.param(key.strip().replace("-", "_"))
        out[param.name] = param.parse(value.strip())
    return out


#: Sample spacing of terrains generated for ``render --generate`` and ``view --generate``.
VIEW_SPACING = 2.0


def progress_total(name: str, size_or_shape: int | Sequence[int], **params: object) -> int | None:
    """How many steps ``progress`` will count for these parameters (``None``: no progress)."""
    gen = get_generator(name)
    if gen.progress_total is None:
        return None
    shape = grid_shape(size_or_shape, algorithm=gen.name)
    return gen.progress_total(resolve_params(gen, shape, params))


__all__ = [
    "DEFAULT_RELIEF_FRACTION",
    "GENERATORS",
    "VIEW_SPACING",
    "Generator",
    "Param",
    "default_relief",
    "generate",
    "generator_names",
    "get_generator",
    "names_help",
    "parse_params",
    "progress_total",
    "resolve_params",
]
