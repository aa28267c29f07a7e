"""What stands on the terrain: object meshes and their instances (plain data, no GL).

An :class:`ObjectMesh` is one low-poly model in its own frame (Y up, its foot at the origin,
world units); an :class:`Instances` set places many copies of several meshes on a terrain.
The renderer draws each mesh once per frame, instanced; exporters write the same lists.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from terrascape.errors import InvalidParameterError


def _array(value, dtype, shape_tail: tuple[int, ...], name: str) -> np.ndarray:
    arr = np.ascontiguousarray(value, dtype=dtype)
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        want = "(n, " + ", ".join(map(str, shape_tail)) + ")" if shape_tail else "(n,)"
        raise InvalidParameterError(f"{name} must have shape {want}, got {arr.shape}")
    if arr.dtype.kind == "f" and not np.isfinite(arr).all():
        raise InvalidParameterError(f"{name} must be finite (NaN or infinity found)")
    return arr


@dataclass(frozen=True, eq=False)
class ObjectMesh:
    """One indexed triangle mesh with per-vertex normals and linear-RGB colours.

    Parameters
    ----------
    name
        What the user calls it (``"conifer"``, a glTF file's stem, ...).
    positions, normals, colors
        float32 ``(V, 3)``; the foot of the object at the origin, Y up, world units.
    indices
        uint32 ``(T, 3)``, counter-clockwise seen from outside.
    """

    name: str
    positions: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    indices: np.ndarray

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError("an object mesh needs a name")
        pos = _array(self.positions, np.float32, (3,), f"{self.name} positions")
        nrm = _array(self.normals, np.float32, (3,), f"{self.name} normals")
        col = _array(self.colors, np.float32, (3,), f"{self.name} colors")
        idx = np.asarray(self.indices)
        if idx.dtype.kind not in "iu":
            raise InvalidParameterError(f"{self.name} indices must be integers")
        idx = _array(idx, np.uint32, (3,), f"{self.name} indices")
        if len(pos) == 0 or len(idx) == 0:
            raise InvalidParameterError(f"{self.name} has no triangles")
        if not (len(nrm) == len(col) == len(pos)):
            raise InvalidParameterError(
                f"{self.name}: positions, normals and colors must have one row per vertex")
        if int(idx.max()) >= len(pos):
            raise InvalidParameterError(f"{self.name} indices point past its {len(pos)} vertices")
        for name, arr in (("positions", pos), ("normals", nrm), ("colors", col),
                          ("indices", idx)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def triangles(self) -> int:
        return len(self.indices)

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)`` corners of the axis-aligned box, float32 ``(3,)`` each."""
        return self.positions.min(axis=0), self.positions.max(axis=0)


@dataclass(frozen=True, eq=False)
class Instances:
    """Copies of several meshes placed in the terrain's world frame.

    Parameters
    ----------
    meshes
        The meshes, in the order ``kind`` indexes them.
    kind
        int32 ``(N,)``: which mesh each instance draws.
    positions
        float32 ``(N, 3)``: world ``(x, y, z)`` of each object's foot (x = column × dx,
        z = row × dz, y = the terrain's height there, as drawn).
    scale
        float32 ``(N,)``: uniform scale (> 0).
    yaw
        float32 ``(N,)``: rotation about +Y in radians (counter-clockwise seen from above).
    """

    meshes: tuple[ObjectMesh, ...]
    kind: np.ndarray
    positions: np.ndarray
    scale: np.ndarray
    yaw: np.ndarray
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        meshes = tuple(self.meshes)
        if not all(isinstance(m, ObjectMesh) for m in meshes):
            raise InvalidParameterError("Instances.meshes must be ObjectMesh values")
        kind = np.asarray(self.kind)
        if kind.size and kind.dtype.kind not in "iu":
            raise InvalidParameterError("instance kinds must be integers")
        kind = _array(kind.reshape(-1), np.int32, (), "instance kinds")
        n = len(kind)
        pos = _array(np.asarray(self.positions, np.float32).reshape(n, 3), np.float32, (3,),
                     "instance positions")
        scale = _array(np.asarray(self.scale, np.float32).reshape(-1), np.float32, (),
                       "instance scales")
        yaw = _array(np.asarray(self.yaw, np.float32).reshape(-1), np.float32, (),
                     "instance yaws")
        if not (len(scale) == len(yaw) == n):
            raise InvalidParameterError("kind, positions, scale and yaw need one row per instance")
        if n and (kind.min() < 0 or kind.max() >= len(meshes)):
            raise InvalidParameterError(f"instance kinds must index the {len(meshes)} meshes")
        if n and not (scale > 0).all():
            raise InvalidParameterError("instance scales must be > 0")
        for name, arr in (("kind", kind), ("positions", pos), ("scale", scale), ("yaw", yaw)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "meshes", meshes)

    def __len__(self) -> int:
        return len(self.kind)

    def of_kind(self, index: int) -> np.ndarray:
        """Indices of the instances drawing mesh ``index``."""
        return np.flatnonzero(self.kind == index)

    def matrices(self) -> np.ndarray:
        """float32 ``(N, 4, 4)`` model matrices (column vectors: ``world = M @ [p, 1]``):
        scale, then yaw about +Y, then translate to the position."""
        n = len(self)
        c = np.cos(self.yaw.astype(np.float64))
        s = np.sin(self.yaw.astype(np.float64))
        k = self.scale.astype(np.float64)
        m = np.zeros((n, 4, 4), np.float64)
        # Counter-clockwise seen from above (+Y toward the eye): x' = x·c + z·s, z' = −x·s + z·c.
        m[:, 0, 0] = c * k
        m[:, 0, 2] = s * k
        m[:, 1, 1] = k
        m[:, 2, 0] = -s * k
        m[:, 2, 2] = c * k
        m[:, :3, 3] = self.positions
        m[:, 3, 3] = 1.0
        return m.astype(np.float32)

    def world_triangles(self, index: int | None = None) -> np.ndarray:
        """float32 ``(T, 3, 3)``: every triangle of every instance (or of instance ``index``)
        in world space — for CPU references (ray casts, shadow volumes)."""
        sel = range(len(self)) if index is None else [int(index)]
        mats = self.matrices()
        out = []
        for i in sel:
            mesh = self.meshes[int(self.kind[i])]
            p = mesh.positions.astype(np.float64) @ mats[i, :3, :3].T.astype(np.float64)
            p += mats[i, :3, 3]
            out.append(p[mesh.indices].astype(np.float32))
        if not out:
            return np.zeros((0, 3, 3), np.float32)
        return np.concatenate(out)
