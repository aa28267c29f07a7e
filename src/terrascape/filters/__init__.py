"""Filters on float heightmaps: smoothing without quantisation (MISSION H6) and thermal /
hydraulic erosion (H7)."""

from terrascape.filters.hydraulic_erosion import hydraulic_erosion
from terrascape.filters.smooth import MODES, box_blur, gaussian_blur
from terrascape.filters.thermal_erosion import thermal_erosion

__all__ = ["MODES", "box_blur", "gaussian_blur", "hydraulic_erosion", "thermal_erosion"]
