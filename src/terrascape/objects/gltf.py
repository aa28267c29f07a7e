"""A user's glTF 2.0 model (``.glb`` or ``.gltf``) as one :class:`ObjectMesh`.

Read with pygltflib; every triangle primitive of every mesh the default scene's nodes draw
is kept (triangles, strips and fans; points and lines are skipped), with the node
transforms (``matrix`` or translation × rotation × scale, down the node tree) applied, and all
of them merged into one mesh in the file's units and axes (glTF: metres, +Y up — the
terrain's). The model's origin is taken as its foot.

Colours, in linear RGB, per vertex: ``COLOR_0`` × the material's ``baseColorFactor`` × its
``baseColorTexture`` sampled at the vertex's ``TEXCOORD_0`` (nearest texel, repeat wrap,
sRGB decoded to linear) — a texture atlas (bark and leaves in one image, common for low-poly
trees) keeps its colours apart. Normals: the file's ``NORMAL`` (transformed by the inverse
transpose), or flat normals where a primitive has none, as the glTF specification says a
viewer must compute. A node whose transform mirrors (negative determinant) has its winding
reversed, again as the specification says.

:func:`load_gltf_copies` reads a file that places copies instead — nodes sharing a mesh, or
``EXT_mesh_gpu_instancing`` (per-instance ``TRANSLATION``, ``ROTATION``, ``SCALE``
accessors) — as each glTF mesh once and every copy's transform.

A file that cannot be read, needs an extension this reader lacks (Draco, meshopt) or holds no
triangles raises :class:`~terrascape.errors.FileFormatError`.

References
----------
The Khronos Group, "glTF 2.0 Specification", 2021 (§3.7 geometry, §3.9 materials).

The Khronos Group, "EXT_mesh_gpu_instancing", glTF extension registry, 2021.
"""

from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError
from terrascape.objects.model import ObjectMesh

__all__ = ["GltfCopies", "load_gltf_copies", "load_gltf_mesh", "places_copies"]

_COMPONENTS = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16,
               5125: np.uint32, 5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
INSTANCING = "EXT_mesh_gpu_instancing"
#: Extensions whose data this reader understands (or may ignore without wrong geometry).
_READABLE = {INSTANCING, "KHR_mesh_quantization", "KHR_materials_unlit", "KHR_texture_transform",
             "KHR_materials_emissive_strength", "KHR_materials_specular", "KHR_materials_ior"}
_TRIANGLES, _STRIP, _FAN = 4, 5, 6


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


class _Reader:
    def __init__(self, doc, path: Path) -> None:
        self.doc = doc
        self.path = path
        self._buffers: dict[int, bytes] = {}
        self._images: dict[int, np.ndarray | None] = {}

    def buffer(self, index: int) -> bytes:
        if index not in self._buffers:
            buf = self.doc.buffers[index]
            if buf.uri is None:
                data = self.doc.binary_blob()
            elif buf.uri.startswith("data:"):
                data = self.doc.decode_data_uri(buf.uri)
            else:
                file = self.path.parent / buf.uri
                try:
                    data = file.read_bytes()
                except OSError as exc:
                    raise FileFormatError(f"{self.path}: cannot read its buffer {file}: "
                                          f"{exc.strerror}") from None
            if data is None or len(data) < (buf.byteLength or 0):
                raise FileFormatError(f"{self.path}: buffer {index} is missing or truncated")
            self._buffers[index] = bytes(data)
        return self._buffers[index]

    def view_bytes(self, index: int) -> bytes:
        view = self.doc.bufferViews[index]
        start = view.byteOffset or 0
        return self.buffer(view.buffer)[start:start + view.byteLength]

    def accessor(self, index: int) -> np.ndarray:
        """float64 (or integer for indices) ``(count, width)``, normalised integers decoded."""
        acc = self.doc.accessors[index]
        dtype = np.dtype(_COMPONENTS[acc.componentType]).newbyteorder("<")
        width = _WIDTH[acc.type]
        count = acc.count
        if acc.bufferView is None:
            arr = np.zeros((count, width), dtype)
        else:
            view = self.doc.bufferViews[acc.bufferView]
            data = self.buffer(view.buffer)
            stride = view.byteStride or dtype.itemsize * width
            start = (view.byteOffset or 0) + (acc.byteOffset or 0)
            need = start + stride * (count - 1) + dtype.itemsize * width if count else start
            if need > len(data):
                raise FileFormatError(f"{self.path}: accessor {index} reads past its buffer")
            arr = np.ndarray((count, width), dtype, buffer=data, offset=start,
                             strides=(stride, dtype.itemsize)).copy()
        if acc.sparse is not None and acc.sparse.count:
            sp = acc.sparse
            idt = np.dtype(_COMPONENTS[sp.indices.componentType]).newbyteorder("<")
            raw = self.view_bytes(sp.indices.bufferView)
            where = np.frombuffer(raw, idt, sp.count, sp.indices.byteOffset or 0)
            raw = self.view_bytes(sp.values.bufferView)
            values = np.frombuffer(raw, dtype, sp.count * width, sp.values.byteOffset or 0)
            arr[where.astype(np.int64)] = values.reshape(sp.count, width)
        if acc.normalized and dtype.kind in "iu":
            top = float(np.iinfo(dtype).max)
            return np.maximum(arr.astype(np.float64) / top, -1.0)
        return arr.astype(np.float64) if dtype.kind == "f" else arr

    def image(self, index: int) -> np.ndarray | None:
        """Linear RGB float ``(h, w, 3)`` of image ``index`` (``None`` if unreadable)."""
        if index not in self._images:
            from PIL import Image

            img = self.doc.images[index]
            try:
                if img.bufferView is not None:
                    data = self.view_bytes(img.bufferView)
                elif img.uri and img.uri.startswith("data:"):
                    data = self.doc.decode_data_uri(img.uri)
                elif img.uri:
                    data = (self.path.parent / img.uri).read_bytes()
                else:
                    data = None
                pixels = None
                if data:
                    rgb = np.asarray(Image.open(io.BytesIO(data)).convert("RGB"), np.float64)
                    pixels = _srgb_to_linear(rgb / 255.0)
            except (OSError, ValueError):
                pixels = None
            self._images[index] = pixels
        return self._images[index]


def _node_matrix(node) -> np.ndarray:
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, np.float64).reshape(4, 4).T  # column-major
    t = np.eye(4)
    if node.translation is not None:
        t[:3, 3] = node.translation
    r = np.eye(4)
    if node.rotation is not None:
        x, y, z, w = (float(v) for v in node.rotation)
        r[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    s = np.eye(4)
    if node.scale is not None:
        s[0, 0], s[1, 1], s[2, 2] = node.scale
    return t @ r @ s


def _faces(mode: int, indices: np.ndarray) -> np.ndarray:
    idx = indices.reshape(-1).astype(np.int64)
    if mode == _TRIANGLES:
        return idx[: len(idx) // 3 * 3].reshape(-1, 3)
    k = np.arange(len(idx) - 2)
    if mode == _STRIP:  # every other triangle flips to keep the winding
        even = k % 2 == 0
        a = np.where(even, idx[k], idx[k + 1])
        b = np.where(even, idx[k + 1], idx[k])
        return np.stack([a, b, idx[k + 2]], axis=1)
    return np.stack([np.full(len(k), idx[0]), idx[k + 1], idx[k + 2]], axis=1)  # fan


def _primitive(reader: _Reader, prim, matrix: np.ndarray):
    doc = reader.doc
    mode = _TRIANGLES if prim.mode is None else prim.mode
    if mode not in (_TRIANGLES, _STRIP, _FAN) or prim.attributes.POSITION is None:
        return None
    pos = reader.accessor(prim.attributes.POSITION)[:, :3]
    n = len(pos)
    if prim.indices is not None:
        indices = reader.accessor(prim.indices)
    else:
        indices = np.arange(n)
    faces = _faces(mode, indices)
    if len(faces) == 0:
        return None
    if faces.min() < 0 or faces.max() >= n:
        raise FileFormatError(f"{reader.path}: a primitive's indices point past its vertices")
    colour = np.ones((n, 3))
    if prim.attributes.COLOR_0 is not None:
        colour = colour * reader.accessor(prim.attributes.COLOR_0)[:, :3]
    if prim.material is not None and prim.material < len(doc.materials or []):
        pbr = doc.materials[prim.material].pbrMetallicRoughness
        if pbr is not None:
            factor = pbr.baseColorFactor or [1.0, 1.0, 1.0, 1.0]
            colour = colour * np.asarray(factor[:3], np.float64)
            tex = pbr.baseColorTexture
            attr = f"TEXCOORD_{tex.texCoord or 0}" if tex is not None else None
            uv_index = getattr(prim.attributes, attr, None) if attr else None
            if tex is not None and uv_index is not None and tex.index < len(doc.textures):
                source = doc.textures[tex.index].source
                img = reader.image(source) if source is not None else None
                if img is not None:
                    uv = reader.accessor(uv_index)[:, :2]
                    h, w = img.shape[:2]
                    # nearest texel, repeat wrap; glTF's v = 0 is the image's first row
                    col = np.floor(np.mod(uv[:, 0], 1.0) * w).astype(np.int64).clip(0, w - 1)
                    row = np.floor(np.mod(uv[:, 1], 1.0) * h).astype(np.int64).clip(0, h - 1)
                    colour = colour * img[row, col]
    mirrored = np.linalg.det(matrix[:3, :3]) < 0
    if mirrored:
        faces = faces[:, [0, 2, 1]]
    world = pos @ matrix[:3, :3].T + matrix[:3, 3]
    if prim.attributes.NORMAL is not None:
        normal = reader.accessor(prim.attributes.NORMAL)[:, :3]
        try:
            normal = normal @ np.linalg.inv(matrix[:3, :3])  # (M⁻¹)ᵀ applied to row vectors
        except np.linalg.LinAlgError:
            raise FileFormatError(f"{reader.path}: a node has a singular transform") from None
        length = np.linalg.norm(normal, axis=1, keepdims=True)
        normal = np.where(length > 0, normal / np.maximum(length, 1e-300), [0.0, 1.0, 0.0])
        return world, normal, colour, faces
    # no normals: flat shading, each triangle its own vertices
    tri = world[faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.where(length > 0, fn / np.maximum(length, 1e-300), [0.0, 1.0, 0.0])
    flat = np.arange(3 * len(faces)).reshape(-1, 3)
    return (tri.reshape(-1, 3), np.repeat(fn, 3, axis=0), colour[faces].reshape(-1, 3), flat)


def _open(p: Path):
    """``(document, reader)`` of the glTF file ``p``, or one clear error."""
    import pygltflib

    if not p.is_file():
        raise FileFormatError(f"{p}: no such glTF file")
    try:
        head = p.read_bytes()[:8]
    except OSError as exc:
        raise FileFormatError(f"{p}: cannot read it ({exc.strerror})") from None
    if head[:4] == b"glTF" and head[4:8] != (2).to_bytes(4, "little"):
        version = int.from_bytes(head[4:8], "little")
        raise FileFormatError(f"{p}: a glb of version {version}; terrascape reads glTF 2.0")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # pygltflib warns on odd chunks; errors follow
            if head[:4] == b"glTF":
                doc = pygltflib.GLTF2.load_binary(p)
            else:
                doc = pygltflib.GLTF2.load_json(p)
    except Exception as exc:  # pygltflib raises anything from IOError to JSON/KeyError
        raise FileFormatError(f"{p}: not a readable glTF file ({type(exc).__name__}: "
                              f"{str(exc)[:120]})") from None
    if doc is None:
        raise FileFormatError(f"{p}: not a readable glTF file")
    unknown = sorted(set(doc.extensionsRequired or []) - _READABLE)
    if unknown:
        raise FileFormatError(f"{p}: needs the glTF extension {unknown[0]}, which terrascape "
                              "cannot read; export it without compression")
    return doc, _Reader(doc, p)


def _mesh_nodes(doc, p: Path) -> list[tuple[object, np.ndarray]]:
    """``(node, world matrix)`` of every node of the default scene that draws a mesh."""
    nodes = doc.nodes or []
    out = []

    def visit(index: int, parent: np.ndarray, depth: int) -> None:
        if depth > 64 or index >= len(nodes):
            raise FileFormatError(f"{p}: its node tree is cyclic or broken")
        node = nodes[index]
        matrix = parent @ _node_matrix(node)
        if node.mesh is not None and node.mesh < len(doc.meshes or []):
            out.append((node, matrix))
        for child in node.children or []:
            visit(child, matrix, depth + 1)

    try:
        scenes = doc.scenes or []
        if scenes:
            roots = scenes[doc.scene or 0].nodes or []
        else:  # no scene: every node that is nobody's child
            children = {c for n in nodes for c in (n.children or [])}
            roots = [i for i in range(len(nodes)) if i not in children]
        for root in roots:
            visit(root, np.eye(4), 0)
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        raise FileFormatError(f"{p}: a broken glTF structure ({type(exc).__name__}: "
                              f"{str(exc)[:120]})") from None
    return out


def _primitives(reader: _Reader, mesh, matrix: np.ndarray, p: Path) -> list:
    try:
        parts = [_primitive(reader, prim, matrix) for prim in mesh.primitives]
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as exc:
        raise FileFormatError(f"{p}: a broken glTF structure ({type(exc).__name__}: "
                              f"{str(exc)[:120]})") from None
    return [part for part in parts if part is not None]


def _merge(parts: list, name: str, p: Path) -> ObjectMesh:
    offset = 0
    positions, normals, colours, faces = [], [], [], []
    for pos, nrm, col, fc in parts:
        positions.append(pos)
        normals.append(nrm)
        colours.append(col)
        faces.append(fc + offset)
        offset += len(pos)
    pos = np.concatenate(positions)
    if not np.isfinite(pos).all():
        raise FileFormatError(f"{p}: vertex positions are not finite")
    return ObjectMesh(name, pos.astype(np.float32),
                      np.concatenate(normals).astype(np.float32),
                      np.clip(np.concatenate(colours), 0.0, 1.0).astype(np.float32),
                      np.concatenate(faces).astype(np.uint32))


def _no_triangles(p: Path) -> FileFormatError:
    return FileFormatError(f"{p}: holds no triangle mesh (only points, lines or nothing); "
                           "objects need triangles")


def load_gltf_mesh(path: str | os.PathLike, *, name: str | None = None) -> ObjectMesh:
    """Every triangle of the glTF/glb file ``path`` as one mesh (see the module docstring).

    Parameters
    ----------
    path
        A ``.glb`` or ``.gltf`` file (external buffers and images next to it are read).
    name
        The mesh's name; default the file's stem.
    """
    p = Path(path)
    doc, reader = _open(p)
    parts = []
    for node, matrix in _mesh_nodes(doc, p):
        parts += _primitives(reader, doc.meshes[node.mesh], matrix, p)
    if not parts:
        raise _no_triangles(p)
    return _merge(parts, name or p.stem, p)


# --- a file that places copies --------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class GltfCopies:
    """The copies of meshes a glTF file places.

    Attributes
    ----------
    meshes
        One mesh per glTF mesh drawn (its primitives merged, in the mesh's own frame).
    kind
        int ``(N,)``: which mesh each copy draws.
    matrices
        float64 ``(N, 4, 4)``: each copy's transform into the file's frame (column vectors):
        the node's transform down the tree, after the copy's own ``EXT_mesh_gpu_instancing``
        translation × rotation × scale.
    """

    meshes: tuple[ObjectMesh, ...]
    kind: np.ndarray
    matrices: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)


def _instance_matrices(reader: _Reader, node, p: Path) -> np.ndarray | None:
    """``(n, 4, 4)`` TRS matrices of a node's EXT_mesh_gpu_instancing, or None."""
    ext = (node.extensions or {}).get(INSTANCING)
    if ext is None:
        return None
    attrs = ext.get("attributes") if isinstance(ext, dict) else None
    if not isinstance(attrs, dict) or not attrs:
        raise FileFormatError(f"{p}: a node's {INSTANCING} has no attributes")
    columns = {}
    for key, width in (("TRANSLATION", 3), ("ROTATION", 4), ("SCALE", 3)):
        if key in attrs:
            try:
                values = reader.accessor(int(attrs[key]))
            except (IndexError, KeyError, TypeError, ValueError) as exc:
                raise FileFormatError(f"{p}: the {INSTANCING} accessor {key} is broken "
                                      f"({type(exc).__name__})") from None
            if values.shape[1] != width:
                raise FileFormatError(f"{p}: {INSTANCING} {key} must be VEC{width}")
            columns[key] = values.astype(np.float64)
    counts = {len(v) for v in columns.values()}
    if len(counts) != 1:
        raise FileFormatError(f"{p}: the {INSTANCING} accessors of a node differ in count "
                              f"({', '.join(f'{k} {len(v)}' for k, v in columns.items())})")
    n = counts.pop()
    m = np.tile(np.eye(4), (n, 1, 1))
    if "ROTATION" in columns:
        q = columns["ROTATION"]
        q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-300)
        x, y, z, w = q.T
        m[:, :3, :3] = np.stack([
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ], axis=1)
    if "SCALE" in columns:
        m[:, :3, :3] = m[:, :3, :3] * columns["SCALE"][:, None, :]
    if "TRANSLATION" in columns:
        m[:, :3, 3] = columns["TRANSLATION"]
    return m


def places_copies(path: str | os.PathLike) -> bool:
    """True when the glTF file ``path`` places copies of its meshes — a node with
    ``EXT_mesh_gpu_instancing``, or one mesh drawn by more than one node — rather than
    holding one model."""
    p = Path(path)
    doc, _ = _open(p)
    drawn = [node.mesh for node, _ in _mesh_nodes(doc, p)]
    instanced = any(INSTANCING in (node.extensions or {}) for node, _ in _mesh_nodes(doc, p))
    return instanced or len(drawn) != len(set(drawn))


def load_gltf_copies(path: str | os.PathLike) -> GltfCopies:
    """Every copy the glTF file ``path`` places: one per node drawing a mesh, or one per
    instance of a node with ``EXT_mesh_gpu_instancing`` (``TRANSLATION``, ``ROTATION``,
    ``SCALE``, each optional; the node's own transform applied after the instance's, as
    the extension specifies)."""
    p = Path(path)
    doc, reader = _open(p)
    meshes: dict[int, ObjectMesh | None] = {}
    names: set[str] = set()
    kind, mats = [], []
    for node, matrix in _mesh_nodes(doc, p):
        index = node.mesh
        if index not in meshes:
            parts = _primitives(reader, doc.meshes[index], np.eye(4), p)
            base = doc.meshes[index].name or f"{p.stem}_{index}"
            name, k = base, 2
            while name in names:
                name, k = f"{base}_{k}", k + 1
            names.add(name)
            meshes[index] = _merge(parts, name, p) if parts else None
        if meshes[index] is None:
            continue
        inst = _instance_matrices(reader, node, p)
        copies = matrix[None] if inst is None else matrix[None] @ inst
        mats.append(copies)
        kind += [index] * len(copies)
    if not mats:
        raise _no_triangles(p)
    order = [i for i in meshes if meshes[i] is not None]
    remap = {i: k for k, i in enumerate(order)}
    matrices = np.concatenate(mats)
    if not np.isfinite(matrices).all():
        raise FileFormatError(f"{p}: a copy's transform is not finite")
    return GltfCopies(tuple(meshes[i] for i in order),
                      np.array([remap[i] for i in kind], np.int64), matrices)
