"""Render meshes (pure numpy, no OpenGL): the terrain grid mesh and per-vertex tangent space."""

from terrascape.mesh.tangent_space import (
    heightfield_tangent_frames,
    orthonormalize_frame,
    tangent_frames,
)
from terrascape.mesh.terrain_mesh import (
    DEFAULT_BAND,
    DEFAULT_CHUNK,
    MeshChunk,
    TerrainMesh,
    banded_grid_triangles,
    grid_triangles,
    terrain_mesh,
)

__all__ = [
    "DEFAULT_BAND",
    "DEFAULT_CHUNK",
    "MeshChunk",
    "TerrainMesh",
    "banded_grid_triangles",
    "grid_triangles",
    "heightfield_tangent_frames",
    "orthonormalize_frame",
    "tangent_frames",
    "terrain_mesh",
]
