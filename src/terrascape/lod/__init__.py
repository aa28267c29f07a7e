"""Level of detail (seed 001 §4–5): ROAM, Turner's ROAM, geomipmapping, quadtree culling, a
static RTIN mesher and the mesh checks they all share.

Triangle format shared by all LOD code: ``uint32 (M, 3)`` grid vertex indices
``row * cols + col``, counter-clockwise seen from above (+Y).
"""

from terrascape.lod.geomipmap import Geomipmap, full_resolution_triangles, patch_templates
from terrascape.lod.mesh_checks import (
    ConformityReport,
    conformity_report,
    is_conforming,
    max_screen_error,
    max_vertical_error,
    sample_errors,
    screen_errors,
)
from terrascape.lod.quadtree import PatchQuadtree, patch_grid
from terrascape.lod.roam import Roam, RoamStats, roam_mesh
from terrascape.lod.rtin import Rtin, RtinMesh, rtin_mesh
from terrascape.lod.turner_roam import TurnerRoam, TurnerStats, turner_variance

__all__ = [
    "ConformityReport",
    "Geomipmap",
    "PatchQuadtree",
    "Roam",
    "RoamStats",
    "Rtin",
    "RtinMesh",
    "TurnerRoam",
    "TurnerStats",
    "conformity_report",
    "full_resolution_triangles",
    "is_conforming",
    "max_screen_error",
    "max_vertical_error",
    "patch_grid",
    "patch_templates",
    "roam_mesh",
    "rtin_mesh",
    "sample_errors",
    "screen_errors",
    "turner_variance",
]
