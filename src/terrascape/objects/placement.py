"""Copies a glTF file places (``EXT_mesh_gpu_instancing``, or nodes sharing a mesh) as
:class:`~terrascape.objects.model.Instances` standing on a terrain.

terrascape draws every object upright: a foot position, a turn about +Y and a uniform scale
(what the renderer's per-instance buffer and every exporter carry). Each copy's 3×3
transform ``A`` is split into that and what is left:

* scale ``s = |det A|^(1/3)``, the volume's scale;
* yaw from where ``A`` puts the mesh's +X axis, seen from above;
* the rest ``B = (R_y(yaw) · s)⁻¹ · A`` — the identity for an upright copy. Copies whose
  rest is not (tilted, stretched or mirrored) get a variant of their mesh with ``B`` applied
  to its vertices, one variant per distinct rest, so they are drawn exactly as the file
  says.

The feet go on the terrain's surface as drawn (:func:`~terrascape.objects.surface.surface_height`)
at the copies' x and z, in the terrain's frame (x east, z south, the glTF's own axes); the
height the file gives is not kept, so a placement made on other heights (or another
exaggeration) still stands on the ground. Copies outside the terrain are left out, with a
warning.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.gltf import GltfCopies
from terrascape.objects.model import Instances, ObjectMesh
from terrascape.objects.surface import surface_height

__all__ = ["MAX_VARIANTS", "OutsideTerrainWarning", "instances_from_copies", "upright_parts"]

#: Most mesh variants (distinct tilts or stretches) a placement may need.
MAX_VARIANTS = 256
_UPRIGHT_TOLERANCE = 1e-4


class OutsideTerrainWarning(UserWarning):
    """Some placed copies stand outside the terrain and were left out."""


def upright_parts(matrices: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(scale (N,), yaw (N,), rest (N, 3, 3))`` of the 3×3 parts of ``matrices``
    (``(N, 4, 4)``): ``A = R_y(yaw) · scale · rest`` (module docstring)."""
    a = np.asarray(matrices, np.float64)[:, :3, :3]
    det = np.linalg.det(a)
    if not (np.abs(det) > 1e-18).all():
        raise InvalidParameterError("a copy's transform is singular (flattened to nothing)")
    scale = np.cbrt(np.abs(det))
    # terrascape's yaw turns +X to (cos, 0, −sin) (Instances.matrices)
    yaw = np.arctan2(-a[:, 2, 0], a[:, 0, 0])
    flat = np.hypot(a[:, 2, 0], a[:, 0, 0]) < 1e-9 * scale  # +X straight up or down
    yaw = np.where(flat, 0.0, np.mod(yaw, 2.0 * math.pi))
    c, s = np.cos(yaw), np.sin(yaw)
    inv_r = np.zeros_like(a)  # R_y(yaw)ᵀ
    inv_r[:, 0, 0], inv_r[:, 0, 2] = c, -s
    inv_r[:, 1, 1] = 1.0
    inv_r[:, 2, 0], inv_r[:, 2, 2] = s, c
    rest = inv_r @ a / scale[:, None, None]
    return scale, yaw, rest


def _variant(mesh: ObjectMesh, rest: np.ndarray, name: str) -> ObjectMesh:
    pos = mesh.positions.astype(np.float64) @ rest.T
    nrm = mesh.normals.astype(np.float64) @ np.linalg.inv(rest)  # (B⁻¹)ᵀ on row vectors
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    faces = mesh.indices
    if np.linalg.det(rest) < 0:  # a mirror turns the winding inside out
        faces = faces[:, [0, 2, 1]]
    return ObjectMesh(name, pos.astype(np.float32), nrm.astype(np.float32), mesh.colors,
                      faces)


def instances_from_copies(copies: GltfCopies, heightmap: Heightmap, *,
                          exaggeration: float = 1.0, max_objects: int | None = None,
                          source: str = "the file") -> Instances:
    """The copies standing on ``heightmap`` (module docstring).

    Parameters
    ----------
    copies
        From :func:`~terrascape.objects.gltf.load_gltf_copies`.
    heightmap, exaggeration
        The terrain and the vertical exaggeration it is drawn with.
    max_objects
        More copies on the terrain than this is an error (None: no limit).
    source
        Names the file in messages.
    """
    if len(copies) == 0:
        raise FileFormatError(f"{source} places no copies")
    mats = np.asarray(copies.matrices, np.float64)
    try:
        scale, yaw, rest = upright_parts(mats)
    except InvalidParameterError as exc:
        raise FileFormatError(f"{source}: {exc}") from None
    x, z = mats[:, 0, 3], mats[:, 2, 3]
    ex, ez = heightmap.extent
    inside = (x >= 0.0) & (x <= ex) & (z >= 0.0) & (z <= ez)
    if not inside.any():
        raise FileFormatError(
            f"{source}: none of its {len(x)} copies stands on the terrain (x 0–{ex:g}, "
            f"z 0–{ez:g}; the copies span x {x.min():g}–{x.max():g}, z {z.min():g}–"
            f"{z.max():g})")
    if not inside.all():
        warnings.warn(f"{source}: {int((~inside).sum())} of its {len(x)} copies stand outside "
                      "the terrain and are left out", OutsideTerrainWarning, stacklevel=2)
    if max_objects is not None and int(inside.sum()) > max_objects:
        raise InvalidParameterError(f"{source} places {int(inside.sum())} objects on the "
                                    f"terrain, more than the limit of {max_objects}")
    keep = np.flatnonzero(inside)
    meshes: list[ObjectMesh] = list(copies.meshes)
    kind = np.asarray(copies.kind, np.int64)[keep].copy()
    upright = np.abs(rest[keep] - np.eye(3)).max(axis=(1, 2)) <= _UPRIGHT_TOLERANCE
    variants: dict[tuple, int] = {}
    for j in np.flatnonzero(~upright):
        i = keep[j]
        key = (int(copies.kind[i]), *np.round(rest[i], 4).ravel().tolist())
        if key not in variants:
            if len(variants) >= MAX_VARIANTS:
                raise FileFormatError(
                    f"{source}: its copies are tilted or stretched in more than "
                    f"{MAX_VARIANTS} different ways; objects on the terrain stand upright "
                    "(a turn about the vertical and one scale), so place them that way")
            base = copies.meshes[int(copies.kind[i])]
            variants[key] = len(meshes)
            meshes.append(_variant(base, rest[i], f"{base.name}~{len(variants)}"))
        kind[j] = variants[key]
    y = surface_height(heightmap, x[keep], z[keep], exaggeration)
    used = np.unique(kind)
    remap = np.full(len(meshes), -1, np.int64)
    remap[used] = np.arange(len(used))
    return Instances(tuple(meshes[k] for k in used), remap[kind],
                     np.c_[x[keep], y, z[keep]], scale[keep], yaw[keep],
                     metadata={"source": source, "exaggeration": float(exaggeration),
                               "copies": len(keep),
                               "variants": len(variants)})
