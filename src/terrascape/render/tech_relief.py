"""Discovery hook: ``get_technique`` imports ``render/tech_*`` modules; this one registers the
relief techniques defined in :mod:`terrascape.render.relief_techniques`."""

from terrascape.render.relief_techniques import register_relief_techniques

__all__ = ["register_relief_techniques"]
