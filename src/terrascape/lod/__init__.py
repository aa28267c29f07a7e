"""Level of detail: ROAM, Turner's ROAM, geomipmapping, quadtree culling, the static
meshers (RTIN and the greedy TIN) and the mesh checks they all share.

Triangle format shared by all LOD code: ``uint32 (M, 3)`` grid vertex indices
``row * cols + col``, counter-clockwise seen from above (+Y).

The view-dependent schemes share one interface (:class:`~terrascape.lod.schemes.LodScheme`)
and are listed in :data:`~terrascape.lod.schemes.SCHEMES`; the static meshers in
:data:`~terrascape.lod.static_meshers.STATIC_MESHERS`. Names are imported on first use
(PEP 562), so ``terrascape.lod.schemes`` and ``terrascape.lod.static_meshers`` — read by
the CLI's ``--help`` — load no numba kernels. The greedy TIN's function is
``terrascape.lod.greedy_tin.greedy_tin`` (its module has the same name, so the package
cannot also offer the function under it).

References
----------
- D. Filipović, "Generiranje i prikaz terena" (Terrain generation and display), BSc thesis 221,
  Faculty of Electrical Engineering and Computing, University of Zagreb, 2008, §4–5.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_EXPORTS = {
    "terrascape.lod.geomipmap": ("Geomipmap", "GeomipmapStats", "full_resolution_triangles",
                                 "patch_templates"),
    "terrascape.lod.mesh_checks": ("ConformityReport", "conformity_report", "is_conforming",
                                   "max_screen_error", "max_vertical_error", "sample_errors",
                                   "screen_errors"),
    "terrascape.lod.quadtree": ("PatchQuadtree", "patch_grid"),
    "terrascape.lod.roam": ("Roam", "RoamStats", "roam_mesh"),
    "terrascape.lod.rtin": ("Rtin", "RtinMesh", "rtin_mesh"),
    "terrascape.lod.schemes": ("SCHEMES", "LodParameter", "LodScheme", "LodStats", "Scheme",
                               "scheme"),
    "terrascape.lod.static_meshers": ("DEFAULT_STATIC_MESHER", "STATIC_MESHERS", "StaticMesher",
                                      "static_mesher"),
    "terrascape.lod.turner_roam": ("TurnerRoam", "TurnerStats", "turner_variance"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

if TYPE_CHECKING:
    from terrascape.lod.geomipmap import (
        Geomipmap,
        GeomipmapStats,
        full_resolution_triangles,
        patch_templates,
    )
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
    from terrascape.lod.schemes import SCHEMES, LodParameter, LodScheme, LodStats, Scheme, scheme
    from terrascape.lod.static_meshers import (
        DEFAULT_STATIC_MESHER,
        STATIC_MESHERS,
        StaticMesher,
        static_mesher,
    )
    from terrascape.lod.turner_roam import TurnerRoam, TurnerStats, turner_variance


def __getattr__(name: str):
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'terrascape.lod' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_WHERE])


__all__ = [
    "DEFAULT_STATIC_MESHER",
    "SCHEMES",
    "STATIC_MESHERS",
    "ConformityReport",
    "Geomipmap",
    "GeomipmapStats",
    "LodParameter",
    "LodScheme",
    "LodStats",
    "PatchQuadtree",
    "Roam",
    "RoamStats",
    "Rtin",
    "RtinMesh",
    "Scheme",
    "StaticMesher",
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
    "scheme",
    "screen_errors",
    "static_mesher",
    "turner_variance",
]
