"""One entry point for every erosion model, with the same float32 masks for each.

:func:`erode` runs one of :data:`MODELS` and returns the eroded map plus masks of the
input's shape:

* ``flow`` — where water runs: drainage area in samples for ``stream-power``, ``droplets``
  and ``thermal`` (D8 over the depression-filled result), the discharge integrated over
  the run for ``grid`` (world units³ per unit width);
* ``deposition`` — height gained, ``max(h − h₀, 0)``;
* ``wear`` — height lost (eroded depth), ``max(h₀ − h, 0)``;
* ``water`` — standing water: the water depth left by ``grid``; for the other models the
  depth of the lakes the result would hold (filled − result).

The default model, ``stream-power``, is the one whose drainage measures like real terrain
(exceedance exponent β ≈ 0.45–0.5, next to no closed depressions; see
``terrascape bench erosion``); ``grid`` is the virtual-pipe water model, ``droplets`` the
particle model and ``thermal`` talus slumping.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrascape._validate import check_positive
from terrascape.analysis.drainage import _heights_and_spacing, _routing
from terrascape.errors import InvalidParameterError
from terrascape.filters.hydraulic_erosion import hydraulic_erosion
from terrascape.filters.stream_power_erosion import stream_power_erosion
from terrascape.filters.thermal_erosion import thermal_erosion
from terrascape.filters.virtual_pipe_erosion import virtual_pipe_erosion
from terrascape.heightmap import Heightmap

MODELS = ("stream-power", "grid", "droplets", "thermal")
DEFAULT_MODEL = "stream-power"
MASK_NAMES = ("flow", "deposition", "wear", "water")

# Yuan et al.'s deposition coefficient G of the stream-power model: fans where rivers leave
# steep ground, β and depressions unchanged (terrascape bench erosion).
DEFAULT_DEPOSITION = 1.0

# Default iterations per model (droplets: None = one droplet per sample).
_DEFAULT_ITERATIONS = {"stream-power": 20, "grid": 300, "droplets": None, "thermal": 50}


@dataclass(frozen=True)
class ErosionResult:
    """The eroded map and its float32 masks (:data:`MASK_NAMES`)."""

    heightmap: Heightmap
    masks: dict[str, np.ndarray] = field(default_factory=dict)


def _drainage_masks(hm: Heightmap) -> tuple[np.ndarray, np.ndarray]:
    h, sx, sz = _heights_and_spacing(hm)
    routing = _routing(h, sx, sz)
    return routing.accumulate().astype(np.float32), (routing.filled - h).astype(np.float32)


def erode(
    heightmap: Heightmap,
    *,
    model: str = DEFAULT_MODEL,
    iterations: int | None = None,
    strength: float = 1.0,
    seed: int = 0,
    talus_angle: float | np.ndarray = 30.0,
    rain: float | np.ndarray | None = None,
    dt: float | None = None,
    evaporation: float | None = None,
    deposition: float = DEFAULT_DEPOSITION,
) -> ErosionResult:
    """Erode ``heightmap`` with ``model`` and return the result with its masks.

    Parameters
    ----------
    heightmap
        Input map.
    model
        One of :data:`MODELS` (default ``stream-power``).
    iterations
        Steps of the model (droplets: number of droplets); default per model
        (stream-power 20, grid 300, droplets one per sample, thermal 50).
    strength
        Multiplies the model's erosion rate (``> 0``; 1 = default): stream-power ``K·dt``,
        grid capacity, droplet erosion share (capped at 1), thermal rate (capped at 0.5).
    seed
        Droplet start positions.
    talus_angle
        Thermal talus in degrees, a number or a per-sample map.
    rain
        Grid rain per second, a number or a per-sample map (default 0.01).
    dt, evaporation
        Grid time step (default half the stable limit; above the limit is refused) and
        evaporation per second (default 0.01; ``evaporation · dt`` must stay below 1).
    deposition
        Stream-power: share of the river load that settles per unit drainage area (Yuan et
        al. 2019's ``G``, ``[0, 10]``; 0 = erode only). The default builds alluvial fans
        where rivers leave steep ground; they show in the ``deposition`` mask.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    if model not in MODELS:
        raise InvalidParameterError(f"model must be one of {', '.join(MODELS)}, got {model!r}")
    strength = check_positive(strength, "strength")
    if iterations is None:
        iterations = _DEFAULT_ITERATIONS[model]
    h0 = heightmap.heights
    masks: dict[str, np.ndarray] = {}
    if model == "stream-power":
        # Routing every 4th step halves the time at the same β and depth of cut
        # (terrascape bench erosion).
        sp = stream_power_erosion(heightmap, iterations=iterations, strength=9e-3 * strength,
                                  routing_interval=4, deposition=deposition)
        out = sp.heightmap
        masks["flow"] = sp.flow
        masks["water"] = _drainage_masks(out)[1]
    elif model == "grid":
        grid = virtual_pipe_erosion(heightmap, iterations=iterations,
                                    rain=0.01 if rain is None else rain,
                                    capacity=0.05 * strength, dt=dt,
                                    evaporation=0.01 if evaporation is None else evaporation)
        out = grid.heightmap
        masks["flow"] = grid.flow
        masks["water"] = grid.water
    elif model == "droplets":
        out = hydraulic_erosion(heightmap, droplets=iterations, seed=seed,
                                erosion=min(0.3 * strength, 1.0))
        masks["flow"], masks["water"] = _drainage_masks(out)
    else:
        out = thermal_erosion(heightmap, iterations=iterations, talus_angle=talus_angle,
                              rate=min(0.5 * strength, 0.5))
        masks["flow"], masks["water"] = _drainage_masks(out)
    dh = out.heights.astype(np.float64) - h0.astype(np.float64)
    masks["deposition"] = np.maximum(dh, 0.0).astype(np.float32)
    masks["wear"] = np.maximum(-dh, 0.0).astype(np.float32)
    for name, mask in masks.items():
        if not np.isfinite(mask).all():
            raise InvalidParameterError(
                f"the {model} model produced NaN/infinite values in the {name} mask; "
                "lower --strength or --iterations")
    return ErosionResult(out, {name: masks[name] for name in MASK_NAMES})


__all__ = ["DEFAULT_DEPOSITION", "DEFAULT_MODEL", "MASK_NAMES", "MODELS", "ErosionResult", "erode"]
