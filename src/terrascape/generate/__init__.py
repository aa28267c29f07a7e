"""Heightmap generators: diamond-square, fault formation, cosine hills (MISSION H3–H5) and
gradient-noise fBm / ridged multifractal (H7)."""

from terrascape.generate.diamond_square import (
    DECAY_LAWS,
    detail_depth,
    diamond_square,
    roughness_schedule,
)
from terrascape.generate.fault import FALLOFFS, fault_formation
from terrascape.generate.hills import hills
from terrascape.generate.noise import fbm, gradient_noise, ridged

__all__ = [
    "DECAY_LAWS",
    "FALLOFFS",
    "detail_depth",
    "diamond_square",
    "fault_formation",
    "fbm",
    "gradient_noise",
    "hills",
    "ridged",
    "roughness_schedule",
]
