"""Filters on float heightmaps: smoothing without quantisation and erosion
thermal, droplet and grid (virtual-pipe) hydraulic, and stream-power fluvial erosion,
with :func:`erode` as the one entry point that also returns flow/deposition/wear/water
masks."""

from terrascape.filters.erosion_models import (
    DEFAULT_MODEL,
    MASK_NAMES,
    MODELS,
    ErosionResult,
    erode,
)
from terrascape.filters.hydraulic_erosion import hydraulic_erosion
from terrascape.filters.smooth import MODES, box_blur, gaussian_blur
from terrascape.filters.stream_power_erosion import StreamPowerResult, stream_power_erosion
from terrascape.filters.thermal_erosion import thermal_erosion
from terrascape.filters.virtual_pipe_erosion import (
    GridErosionResult,
    stable_time_step,
    virtual_pipe_erosion,
)

__all__ = [
    "DEFAULT_MODEL",
    "MASK_NAMES",
    "MODELS",
    "MODES",
    "ErosionResult",
    "GridErosionResult",
    "StreamPowerResult",
    "box_blur",
    "erode",
    "gaussian_blur",
    "hydraulic_erosion",
    "stable_time_step",
    "stream_power_erosion",
    "thermal_erosion",
    "virtual_pipe_erosion",
]
