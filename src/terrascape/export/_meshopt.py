"""``EXT_meshopt_compression`` for glTF buffer views, with meshoptimizer's codecs.

The extension stores each vertex-attribute and index buffer view compressed by
meshoptimizer's vertex codec (byte-wise deltas between consecutive vertices, bit-packed) and
index codec (triangle edges against a FIFO of recent edges and vertices); a viewer decodes
them back to the exact bytes (lossless) before upload. Together with
``KHR_mesh_quantization`` (small integer attributes) that is what ``gltfpack -c`` writes.

Both codecs gain from order: :func:`compression_order` puts the triangles in vertex-cache
order (Forsyth's algorithm as refined in meshoptimizer) and numbers the vertices in order of
first use, so most indices are "the next new vertex" or a recently used one, and neighbouring
vertices — close on the terrain — have small deltas.

The glTF vertex codec is version 0 (the one ``EXT_meshopt_compression`` specifies); the index
codec is version 1.

References
----------
A. Kapoulkine, "meshoptimizer: mesh optimization library", https://meshoptimizer.org.
The Khronos Group, "EXT_meshopt_compression", 2021.
T. Forsyth, "Linear-speed vertex cache optimisation", 2006.
"""

from __future__ import annotations

import numpy as np

from terrascape.errors import EnvironmentFailure, InvalidParameterError

__all__ = ["EXTENSION", "compress_attributes", "compress_indices", "compression_order"]

EXTENSION = "EXT_meshopt_compression"


def _meshopt():
    try:
        import meshoptimizer
    except ImportError as exc:  # the export extra installs it
        raise EnvironmentFailure(
            "glb compression needs the meshoptimizer package: pip install 'terrascape[export]'"
        ) from exc
    return meshoptimizer


def compression_order(faces: np.ndarray, n_vertices: int, *,
                      group: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Triangles in vertex-cache order and a vertex order of first use.

    Parameters
    ----------
    faces
        ``(M, 3)`` vertex indices.
    n_vertices
        Number of vertices.
    group
        Optional ``(n_vertices,)`` integer key: vertices are sorted by it first (stably), then
        by first use — e.g. to keep skirt vertices after the surface's.

    Returns
    -------
    (faces, order)
        ``faces`` renumbered for the new vertex order, and ``order`` such that new vertex ``i``
        is old vertex ``order[i]``. Every triangle keeps its winding.
    """
    mo = _meshopt()
    f = np.ascontiguousarray(faces, dtype=np.uint32)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InvalidParameterError(f"faces must have shape (M, 3), got {f.shape}")
    flat = f.reshape(-1)
    cached = np.empty_like(flat)
    mo.optimize_vertex_cache(cached, flat, flat.size, int(n_vertices))
    used, first = np.unique(cached, return_index=True)
    rank = np.full(n_vertices, np.iinfo(np.int64).max, np.int64)
    rank[used] = first  # unused vertices (none in an export mesh) go last
    keys = (rank,) if group is None else (rank, np.asarray(group))
    order = np.lexsort(keys)
    new_index = np.empty(n_vertices, np.int64)
    new_index[order] = np.arange(n_vertices)
    return new_index[cached.astype(np.int64)].reshape(-1, 3).astype(np.uint32), order


def compress_attributes(data: np.ndarray) -> bytes:
    """One ``ATTRIBUTES``-mode stream of ``data`` (``(count, stride)`` uint8, stride a
    multiple of 4, at most 256)."""
    mo = _meshopt()
    arr = np.ascontiguousarray(data, dtype=np.uint8)
    if arr.ndim != 2 or arr.shape[1] % 4 or not 0 < arr.shape[1] <= 256:
        raise InvalidParameterError(
            f"vertex data must be (count, stride) bytes, stride 4…256 and a multiple of 4; "
            f"got {arr.shape}")
    mo.encode_vertex_version(0)
    return mo.encode_vertex_buffer(arr, arr.shape[0], arr.shape[1])


def compress_indices(indices: np.ndarray) -> bytes:
    """One ``TRIANGLES``-mode stream of ``indices`` (a multiple of 3 of them)."""
    mo = _meshopt()
    flat = np.ascontiguousarray(indices, dtype=np.uint32).reshape(-1)
    if flat.size == 0 or flat.size % 3:
        raise InvalidParameterError(f"need whole triangles, got {flat.size} indices")
    mo.encode_index_version(1)
    return mo.encode_index_buffer(flat, flat.size, int(flat.max()) + 1)
