"""Mesh export: OBJ, binary PLY and glTF 2.0 binary (GLB), written atomically.

LOD code produces triangles as grid vertex indices (``row·cols + col``); :func:`compact_mesh`
turns them into a compact vertex array in world units (``x = col·dx``, ``y = h``,
``z = row·dz``, Y up — also glTF's convention) and re-indexed faces. Faces keep their
counter-clockwise-from-above winding, which is glTF's front face for a Y-up normal.
"""

from __future__ import annotations

import json
import os
import struct
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import atomic_output

__all__ = [
    "MESH_FORMATS",
    "compact_mesh",
    "glb_bytes",
    "vertex_normals",
    "write_glb",
    "write_mesh",
    "write_obj",
    "write_ply",
]

MESH_FORMATS = (".obj", ".ply", ".glb")

# glTF constants
_FLOAT = 5126
_UNSIGNED_INT = 5125
_ARRAY_BUFFER = 34962
_ELEMENT_ARRAY_BUFFER = 34963
_TRIANGLES = 4
_GLB_MAGIC = 0x46546C67  # "glTF"
_CHUNK_JSON = 0x4E4F534A  # "JSON"
_CHUNK_BIN = 0x004E4942  # "BIN\0"


def compact_mesh(heightmap: Heightmap, triangles) -> tuple[np.ndarray, np.ndarray]:
    """Vertices actually used by ``triangles`` and faces re-indexed onto them.

    Parameters
    ----------
    heightmap
        :class:`~terrascape.Heightmap` the grid indices refer to.
    triangles
        ``(M, 3)`` grid vertex indices ``row·cols + col``.

    Returns
    -------
    vertices : numpy.ndarray
        float32 ``(N, 3)`` world positions ``(col·dx, h, row·dz)``, in increasing grid-index
        order.
    faces : numpy.ndarray
        uint32 ``(M, 3)`` indices into ``vertices``, same order and winding as the input.
    """
    if not isinstance(heightmap, Heightmap):
        raise InvalidParameterError(f"expected a Heightmap, got {type(heightmap).__name__}")
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise InvalidParameterError(f"triangles must have shape (M>0, 3), got {tri.shape}")
    if not np.issubdtype(tri.dtype, np.integer):
        raise InvalidParameterError(f"triangles must be integer indices, got dtype {tri.dtype}")
    rows, cols = heightmap.shape
    tri = tri.astype(np.int64)
    if tri.min() < 0 or tri.max() >= rows * cols:
        raise InvalidParameterError(
            f"triangle indices must be in [0, {rows * cols - 1}], got "
            f"[{int(tri.min())}, {int(tri.max())}]"
        )
    used, inverse = np.unique(tri.reshape(-1), return_inverse=True)
    r, c = used // cols, used % cols
    dx, dz = heightmap.spacing
    vertices = np.empty((used.size, 3), np.float32)
    vertices[:, 0] = c * dx
    vertices[:, 1] = heightmap.heights.reshape(-1)[used]
    vertices[:, 2] = r * dz
    faces = inverse.reshape(-1, 3).astype(np.uint32)
    return vertices, faces


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (float32 ``(N, 3)``) of a CCW-from-above mesh."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    # (p1 - p0) × (p2 - p0) has +Y for CCW-from-above faces; its length is twice the area
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), np.array([0.0, 1.0, 0.0]))
    return n.astype(np.float32)


def _check_mesh(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    v = np.ascontiguousarray(vertices, dtype=np.float32)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0:
        raise InvalidParameterError(f"vertices must have shape (N>0, 3), got {v.shape}")
    if f.ndim != 2 or f.shape[1] != 3 or f.shape[0] == 0:
        raise InvalidParameterError(f"faces must have shape (M>0, 3), got {f.shape}")
    if not np.issubdtype(f.dtype, np.integer):
        raise InvalidParameterError(f"faces must be integer indices, got dtype {f.dtype}")
    if f.min() < 0 or f.max() >= len(v):
        raise InvalidParameterError(
            f"face indices must be in [0, {len(v) - 1}], got [{int(f.min())}, {int(f.max())}]"
        )
    if not np.isfinite(v).all():
        raise InvalidParameterError("vertices must be finite")
    return v, np.ascontiguousarray(f, dtype=np.uint32)


def write_obj(path: str | os.PathLike, vertices, faces, *, force: bool = False,
              normals: bool = True) -> Path:
    """Write a Wavefront OBJ (``v``, optional ``vn``, 1-based ``f``), atomically.

    Coordinates are written with 9 significant digits, which round-trips float32 exactly.
    """
    v, f = _check_mesh(vertices, faces)
    with atomic_output(path, force=force) as tmp, open(tmp, "w", encoding="ascii") as fh:
        fh.write("# terrascape mesh\n")
        fh.write(f"# {len(v)} vertices, {len(f)} triangles\n")
        np.savetxt(fh, v, fmt="v %.9g %.9g %.9g")
        f1 = f.astype(np.int64) + 1
        if normals:
            np.savetxt(fh, vertex_normals(v, f), fmt="vn %.6f %.6f %.6f")
            np.savetxt(fh, np.repeat(f1, 2, axis=1), fmt="f %d//%d %d//%d %d//%d")
        else:
            np.savetxt(fh, f1, fmt="f %d %d %d")
    return Path(path)


def write_ply(path: str | os.PathLike, vertices, faces, *, force: bool = False) -> Path:
    """Write a binary little-endian PLY (float x, y, z; uchar-counted uint faces), atomically."""
    v, f = _check_mesh(vertices, faces)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment terrascape mesh\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(f)}\nproperty list uchar uint vertex_indices\nend_header\n"
    ).encode("ascii")
    face_rec = np.empty(len(f), dtype=np.dtype([("n", "u1"), ("i", "<u4", (3,))]))
    face_rec["n"] = 3
    face_rec["i"] = f
    with atomic_output(path, force=force) as tmp, open(tmp, "wb") as fh:
        fh.write(header)
        fh.write(v.astype("<f4").tobytes())
        fh.write(face_rec.tobytes())
    return Path(path)


def _pad4(data: bytes, fill: bytes) -> bytes:
    return data + fill * ((-len(data)) % 4)


def glb_bytes(vertices, faces) -> bytes:
    """The GLB file content: one mesh, POSITION + NORMAL (float32 VEC3) and UNSIGNED_INT
    indices, each in its own 4-byte-aligned bufferView of one BIN chunk."""
    v, f = _check_mesh(vertices, faces)
    n = vertex_normals(v, f)
    pos_bytes = v.astype("<f4").tobytes()
    nrm_bytes = n.astype("<f4").tobytes()
    idx_bytes = f.astype("<u4").tobytes()
    # every view length is a multiple of 4 already (float32/uint32 data)
    views, offset = [], 0
    for data, target in ((pos_bytes, _ARRAY_BUFFER), (nrm_bytes, _ARRAY_BUFFER),
                         (idx_bytes, _ELEMENT_ARRAY_BUFFER)):
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(data),
                      "target": target})
        offset += len(data)
    binary = pos_bytes + nrm_bytes + idx_bytes
    gltf = {
        "asset": {"version": "2.0", "generator": "terrascape"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "terrain"}],
        "meshes": [{
            "name": "terrain",
            "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                            "mode": _TRIANGLES}],
        }],
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": views,
        "accessors": [
            {"bufferView": 0, "byteOffset": 0, "componentType": _FLOAT, "count": len(v),
             "type": "VEC3", "min": [float(x) for x in v.min(axis=0)],
             "max": [float(x) for x in v.max(axis=0)]},
            {"bufferView": 1, "byteOffset": 0, "componentType": _FLOAT, "count": len(v),
             "type": "VEC3", "min": [float(x) for x in n.min(axis=0)],
             "max": [float(x) for x in n.max(axis=0)]},
            {"bufferView": 2, "byteOffset": 0, "componentType": _UNSIGNED_INT,
             "count": int(f.size), "type": "SCALAR",
             "min": [int(f.min())], "max": [int(f.max())]},
        ],
    }
    json_chunk = _pad4(json.dumps(gltf, separators=(",", ":")).encode("utf-8"), b" ")
    bin_chunk = _pad4(binary, b"\x00")
    total = 12 + 8 + len(json_chunk) + 8 + len(bin_chunk)
    return b"".join([
        struct.pack("<III", _GLB_MAGIC, 2, total),
        struct.pack("<II", len(json_chunk), _CHUNK_JSON), json_chunk,
        struct.pack("<II", len(bin_chunk), _CHUNK_BIN), bin_chunk,
    ])


def write_glb(path: str | os.PathLike, vertices, faces, *, force: bool = False) -> Path:
    """Write a glTF 2.0 binary (GLB) file, atomically; see :func:`glb_bytes`."""
    data = glb_bytes(vertices, faces)
    with atomic_output(path, force=force) as tmp:
        Path(tmp).write_bytes(data)
    return Path(path)


def write_mesh(path: str | os.PathLike, vertices, faces, *, force: bool = False) -> Path:
    """Write OBJ, PLY or GLB chosen by the file extension."""
    suffix = Path(path).suffix.lower()
    writers = {".obj": write_obj, ".ply": write_ply, ".glb": write_glb}
    if suffix not in writers:
        raise FileFormatError(
            f"unknown mesh format {suffix or '(no extension)'!r} for {path}; "
            f"expected one of {', '.join(MESH_FORMATS)}"
        )
    return writers[suffix](path, vertices, faces, force=force)
