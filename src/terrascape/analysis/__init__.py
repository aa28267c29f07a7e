"""Measurements on heightmaps used by the report (Filipović 2008 §5.3.1)."""

from terrascape.analysis.spectrum import radial_power_spectrum, spectral_slope

__all__ = ["radial_power_spectrum", "spectral_slope"]
