"""Textured, compact glTF 2.0 binary (GLB) terrain, assembled with pygltflib.

One mesh primitive with ``POSITION``, ``NORMAL``, ``TEXCOORD_0`` (and ``TANGENT`` when a normal
map is attached), a PBR material (metallic 0, roughness 1) whose base colour is the CPU terrain
texture — height regions (:func:`terrascape.texture.region_texture`) multiplied by the baked
light (:func:`terrascape.lighting.lightmap`, sun and cast shadows) — and optionally a
tangent-space normal map (:func:`terrascape.lighting.tangent_space_normals`).

Compactness: indices are ``UNSIGNED_SHORT`` when every index fits (< 65535 vertices), else
``UNSIGNED_INT``; ``split_uint16=True`` cuts a bigger mesh into primitives of fewer vertices
so that every index is 16-bit (WebGL 1 without ``OES_element_index_uint``; glTF 2.0 itself,
Blender, Godot, Unity's glTFast and three.js on WebGL 2 take 32-bit indices). With
``quantize=True`` the file uses ``KHR_mesh_quantization``: positions as normalised ``SHORT``
(the node's scale and translation turn them back into world units, so a position is within
``extent / 65534 / 2`` of the original), normals as normalised ``BYTE`` and texture
coordinates as normalised ``UNSIGNED_SHORT``. ``compress=True`` adds
``EXT_meshopt_compression`` (:mod:`terrascape.export._meshopt`, lossless): about 0.2× the
plain file's bytes, read by three.js, Babylon.js and glTFast, not by Blender or Godot.

Georeference: the root node's ``extras`` carry ``crs``, the CRS coordinates of vertex
``(0, 0)`` (the centre of sample ``[0, 0]``), the spacing and the axis convention (glTF +X = east,
+Y = up, +Z = south). With ``georeference_node=True`` and a projected CRS the root node's
translation also moves the mesh to its CRS coordinates (``x = east``, ``z = −north``) — right
for GIS viewers, but far from the origin for game engines, hence off by default.

References
----------
The Khronos Group, "glTF 2.0 Specification", 2021; "KHR_mesh_quantization", 2020;
"EXT_meshopt_compression", 2021.
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pygltflib
from PIL import Image

from terrascape.errors import InvalidParameterError
from terrascape.export.meshing import TerrainMesh, terrain_mesh, uint16_parts
from terrascape.heightmap import Heightmap
from terrascape.io.atomic import atomic_output
from terrascape.lod.static_meshers import static_mesher
from terrascape.memory import check_triangles

__all__ = ["bake_texture", "build_glb", "compression_ordered", "glb_bytes", "glb_document",
           "write_terrain_glb"]

_BYTE, _UNSIGNED_BYTE, _SHORT, _UNSIGNED_SHORT, _UNSIGNED_INT, _FLOAT = (
    5120, 5121, 5122, 5123, 5125, 5126)
_QUANTIZATION = "KHR_mesh_quantization"


def bake_texture(
    heightmap: Heightmap,
    *,
    sun: tuple[float, float] = (135.0, 35.0),
    max_size: int = 4096,
    seed: int = 0,
) -> np.ndarray:
    """Base colour: height-region texture × lightmap (sun azimuth, elevation; cast shadows).

    Maps larger than ``max_size`` per side are textured on a smoothly resampled copy (a glTF
    viewer's GPU limit is 4096–16384 texels).

    Returns
    -------
    numpy.ndarray
        uint8 ``(rows', cols', 3)`` RGB, row 0 = heightmap row 0 (glTF ``v = 0``).
    """
    from scipy import ndimage

    from terrascape.lighting import lightmap
    from terrascape.texture import region_texture

    hm = heightmap
    longest = max(hm.shape)
    if longest > max_size:
        f = (max_size - 1) / (longest - 1)
        small = ndimage.zoom(hm.heights, f, order=1, grid_mode=False)
        ex, ez = hm.extent
        hm = Heightmap(small, (ex / (small.shape[1] - 1), ez / (small.shape[0] - 1)))
    light = lightmap(hm, sun[0], sun[1], shadows=True)
    return region_texture(hm, lightmap=light, seed=seed)


def _png(image: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", optimize=False, compress_level=6)
    return buf.getvalue()


def _quantise_unit(values: np.ndarray, dtype, maxval: int) -> np.ndarray:
    return np.clip(np.rint(values * maxval), -maxval, maxval).astype(dtype)


class _Buffer:
    """Accumulates 4-byte aligned buffer views and accessors into one GLB binary chunk.

    With ``compress`` every vertex-attribute and index view is stored ``EXT_meshopt_compression``
    encoded in the binary chunk (buffer 0) and points into a fallback buffer (buffer 1, no
    data) of the decoded size, as the extension specifies.
    """

    def __init__(self, doc: pygltflib.GLTF2, *, compress: bool = False) -> None:
        self.doc = doc
        self.blob = bytearray()
        self.compress = compress
        self.fallback_length = 0

    def _append(self, data: bytes) -> int:
        self.blob.extend(b"\x00" * ((-len(self.blob)) % 4))
        offset = len(self.blob)
        self.blob.extend(data)
        return offset

    def view(self, data: bytes, *, target: int | None = None, stride: int | None = None) -> int:
        offset = self._append(data)
        self.doc.bufferViews.append(pygltflib.BufferView(
            buffer=0, byteOffset=offset, byteLength=len(data), target=target,
            byteStride=stride))
        return len(self.doc.bufferViews) - 1

    def compressed_view(self, raw: np.ndarray, *, target: int, count: int) -> int:
        """A view of ``raw`` (``(count, stride)`` bytes) stored meshopt-compressed."""
        from terrascape.export._meshopt import EXTENSION, compress_attributes, compress_indices

        stride = raw.shape[1]
        if target == pygltflib.ELEMENT_ARRAY_BUFFER:
            encoded, mode = compress_indices(raw.view(f"<u{stride}").reshape(-1)), "TRIANGLES"
        else:
            encoded, mode = compress_attributes(raw), "ATTRIBUTES"
        offset = self._append(encoded)
        self.fallback_length += (-self.fallback_length) % 4
        view = pygltflib.BufferView(
            buffer=1, byteOffset=self.fallback_length, byteLength=raw.size, target=target,
            byteStride=None if target == pygltflib.ELEMENT_ARRAY_BUFFER else stride,
            extensions={EXTENSION: {"buffer": 0, "byteOffset": offset,
                                    "byteLength": len(encoded), "byteStride": stride,
                                    "count": count, "mode": mode}})
        self.fallback_length += raw.size
        self.doc.bufferViews.append(view)
        return len(self.doc.bufferViews) - 1

    def accessor(self, array: np.ndarray, component: int, kind: str, *, target: int | None,
                 normalized: bool = False, bounds: bool = False) -> int:
        arr = np.ascontiguousarray(array)
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[kind]
        item = arr.dtype.itemsize * width
        stride = None
        if target == pygltflib.ARRAY_BUFFER and item % 4:
            # vertex attributes must be 4-byte aligned per element: pad each to a multiple of 4
            pad = (-item) % 4 // arr.dtype.itemsize
            arr = np.concatenate([arr.reshape(len(arr), width),
                                  np.zeros((len(arr), pad), arr.dtype)], axis=1)
            stride = item + pad * arr.dtype.itemsize
        little = np.ascontiguousarray(arr.astype(arr.dtype.newbyteorder("<")))
        if self.compress and target is not None:
            per_element = little.dtype.itemsize * (1 if target != pygltflib.ARRAY_BUFFER else
                                                   little.size // max(len(little), 1))
            raw = little.view(np.uint8).reshape(-1, per_element)
            view = self.compressed_view(raw, target=target, count=len(raw))
        else:
            view = self.view(little.tobytes(), target=target, stride=stride)
        shaped = np.asarray(array).reshape(len(array), width)
        acc = pygltflib.Accessor(bufferView=view, byteOffset=0, componentType=component,
                                 count=len(array), type=kind, normalized=normalized or None)
        if bounds:
            lo, hi = shaped.min(axis=0), shaped.max(axis=0)
            cast = float if np.issubdtype(shaped.dtype, np.floating) else int
            acc.min = [cast(v) for v in lo]
            acc.max = [cast(v) for v in hi]
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1


def _tangents(normals: np.ndarray) -> np.ndarray:
    """Unit tangents along +X (texture +u) orthogonal to the normal; w = −1 puts the bitangent
    ``cross(N, T)·w`` along +Z (texture +v), the frame of ``tangent_space_normals``."""
    x = np.array([1.0, 0.0, 0.0])
    n = normals.astype(np.float64)
    t = x - n * (n @ x)[:, None]
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return np.concatenate([t, -np.ones((len(t), 1))], axis=1).astype(np.float32)


def glb_document(
    mesh: TerrainMesh,
    *,
    base_colour: np.ndarray | None = None,
    normal_texture: np.ndarray | None = None,
    quantize: bool = False,
    compress: bool = False,
    split_uint16: bool = False,
    extras: dict | None = None,
    root_translation: tuple[float, float, float] | None = None,
    name: str = "terrain",
) -> pygltflib.GLTF2:
    """The glTF document (with its binary blob set) for ``mesh``; see the module docstring.

    ``compress`` stores the geometry ``EXT_meshopt_compression`` encoded (give it a mesh in
    :func:`compression_ordered` order to make it small). ``split_uint16`` cuts a mesh of
    65 535 vertices or more into primitives that each have fewer, so every primitive has
    ``UNSIGNED_SHORT`` indices (vertices on a cut are repeated in both primitives).
    """
    doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="terrascape"))
    buf = _Buffer(doc, compress=compress)
    pos = mesh.positions
    n_vert = len(pos)
    mesh_node = pygltflib.Node(name=f"{name}-mesh")
    extensions: list[str] = []
    if quantize:
        lo, hi = pos.min(axis=0), pos.max(axis=0)
        centre = (lo + hi) / 2.0
        half = np.where(hi > lo, (hi - lo) / 2.0, 1.0)
        mesh_node.translation = [float(v) for v in centre]
        mesh_node.scale = [float(v) for v in half]
        columns = {
            "POSITION": (np.clip(np.rint((pos - centre) / half * 32767.0), -32767, 32767
                                 ).astype(np.int16), _SHORT, "VEC3", True),
            "NORMAL": (_quantise_unit(mesh.normals, np.int8, 127), _BYTE, "VEC3", True),
            "TEXCOORD_0": (np.clip(np.rint(mesh.uvs * 65535.0), 0, 65535).astype(np.uint16),
                           _UNSIGNED_SHORT, "VEC2", True),
        }
        extensions.append(_QUANTIZATION)
    else:
        columns = {
            "POSITION": (pos.astype(np.float32), _FLOAT, "VEC3", False),
            "NORMAL": (mesh.normals.astype(np.float32), _FLOAT, "VEC3", False),
            "TEXCOORD_0": (mesh.uvs.astype(np.float32), _FLOAT, "VEC2", False),
        }
    if normal_texture is not None:
        columns["TANGENT"] = (_tangents(mesh.normals), _FLOAT, "VEC4", False)
    if compress:
        from terrascape.export._meshopt import EXTENSION

        extensions.append(EXTENSION)
    if split_uint16 and n_vert >= 65535:
        parts = uint16_parts(mesh.faces)
    else:
        parts = [(None, mesh.faces)]
    primitives = []
    for vertex_ids, faces in parts:
        attributes = pygltflib.Attributes()
        for key, (values, component, kind, normalized) in columns.items():
            part_values = values if vertex_ids is None else values[vertex_ids]
            setattr(attributes, key, buf.accessor(
                part_values, component, kind, target=pygltflib.ARRAY_BUFFER,
                normalized=normalized, bounds=key == "POSITION"))
        count = n_vert if vertex_ids is None else len(vertex_ids)
        # 65535 is the primitive-restart value, so uint16 indices need fewer vertices than that
        small = count < 65535
        indices = buf.accessor(faces.reshape(-1).astype(np.uint16 if small else np.uint32),
                               _UNSIGNED_SHORT if small else _UNSIGNED_INT, "SCALAR",
                               target=pygltflib.ELEMENT_ARRAY_BUFFER, bounds=True)
        primitives.append(pygltflib.Primitive(attributes=attributes, indices=indices,
                                              mode=pygltflib.TRIANGLES))
    if base_colour is not None or normal_texture is not None:
        doc.samplers.append(pygltflib.Sampler(
            magFilter=pygltflib.LINEAR, minFilter=pygltflib.LINEAR_MIPMAP_LINEAR,
            wrapS=pygltflib.CLAMP_TO_EDGE, wrapT=pygltflib.CLAMP_TO_EDGE))
        material = pygltflib.Material(
            name=f"{name}-material",
            pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(metallicFactor=0.0,
                                                                 roughnessFactor=1.0),
            doubleSided=False)

        def add_texture(image: np.ndarray) -> int:
            view = buf.view(_png(image))
            doc.images.append(pygltflib.Image(bufferView=view, mimeType="image/png"))
            doc.textures.append(pygltflib.Texture(sampler=0, source=len(doc.images) - 1))
            return len(doc.textures) - 1

        if base_colour is not None:
            material.pbrMetallicRoughness.baseColorTexture = pygltflib.TextureInfo(
                index=add_texture(base_colour))
        if normal_texture is not None:
            material.normalTexture = pygltflib.NormalMaterialTexture(
                index=add_texture(normal_texture))
        doc.materials.append(material)
        for primitive in primitives:
            primitive.material = 0
    if extensions:
        doc.extensionsUsed = list(extensions)
        doc.extensionsRequired = list(extensions)
    doc.meshes.append(pygltflib.Mesh(name=name, primitives=primitives))
    mesh_node.mesh = 0
    root = pygltflib.Node(name=name, children=[1], extras=extras or {})
    if root_translation is not None:
        root.translation = [float(v) for v in root_translation]
    doc.nodes = [root, mesh_node]
    doc.scenes = [pygltflib.Scene(nodes=[0])]
    doc.scene = 0
    doc.buffers = [pygltflib.Buffer(byteLength=len(buf.blob))]
    if compress:
        from terrascape.export._meshopt import EXTENSION

        # the fallback buffer has no data: a viewer must decode (extension required)
        doc.buffers.append(pygltflib.Buffer(byteLength=buf.fallback_length,
                                            extensions={EXTENSION: {"fallback": True}}))
    doc.set_binary_blob(bytes(buf.blob))
    return doc


def glb_bytes(doc: pygltflib.GLTF2) -> bytes:
    """The GLB file of ``doc`` (its binary blob as the BIN chunk).

    pygltflib writes a GLB with one buffer only (it merges them), so a document with the
    ``EXT_meshopt_compression`` fallback buffer — which must stay a separate buffer without
    data — is framed here: the 12-byte header and the JSON and BIN chunks, each padded to 4
    bytes (JSON with spaces, BIN with zeros) as the GLB container specifies.
    """
    if len(doc.buffers) <= 1:
        return b"".join(doc.save_to_bytes())
    import struct

    blob = bytes(doc.binary_blob() or b"")
    blob += b"\x00" * ((-len(blob)) % 4)
    doc.buffers[0].byteLength = len(blob)
    text = doc.gltf_to_json(separators=(",", ":"), indent=None).encode("utf-8")
    text += b" " * ((-len(text)) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    return b"".join([b"glTF", struct.pack("<II", 2, total),
                     struct.pack("<I", len(text)), b"JSON", text,
                     struct.pack("<I", len(blob)), b"BIN\x00", blob])


def compression_ordered(mesh: TerrainMesh) -> TerrainMesh:
    """``mesh`` with its triangles and vertices in the order meshopt compresses best
    (:func:`terrascape.export._meshopt.compression_order`); skirt vertices stay last."""
    from terrascape.export._meshopt import compression_order

    n = len(mesh.positions)
    group = np.zeros(n, np.int8)
    if mesh.skirt_vertices:
        group[n - mesh.skirt_vertices:] = 1
    faces, order = compression_order(mesh.faces, n, group=group)
    return TerrainMesh(mesh.positions[order], mesh.normals[order], mesh.uvs[order], faces,
                       mesh.grid_index[order], mesh.skirt_vertices)


def _georeference(heightmap: Heightmap) -> tuple[dict, tuple[float, float, float] | None]:
    extras: dict = {
        "generator": "terrascape",
        "spacing": list(heightmap.spacing),
        "axes": "x east, y up, z south (rows); vertex (0, 0) is the centre of sample [0, 0]",
        "height_range": [heightmap.min, heightmap.max],
    }
    if heightmap.crs is None:
        return extras, None
    from terrascape.io.geotiff import crs_pixel_size

    px, py = crs_pixel_size(heightmap)
    x0 = heightmap.origin[0] + 0.5 * px
    y0 = heightmap.origin[1] - 0.5 * py
    extras.update(crs=heightmap.crs, first_sample_centre=[x0, y0], pixel_size=[px, py])
    geographic = bool(heightmap.metadata.get("geographic"))
    return extras, (None if geographic else (x0, 0.0, -y0))


def build_glb(
    heightmap: Heightmap,
    triangles: np.ndarray,
    *,
    texture: bool = True,
    normal_map: bool = False,
    quantize: bool = False,
    compress: bool = False,
    split_uint16: bool = False,
    skirt: float = 0.0,
    georeference_node: bool = False,
    sun: tuple[float, float] = (135.0, 35.0),
    texture_size: int = 4096,
    objects=None,
) -> tuple[bytes, TerrainMesh]:
    """GLB bytes and the mesh they hold, for ``triangles`` (grid indices) of ``heightmap``;
    ``objects`` (:class:`~terrascape.objects.Instances`) adds them with GPU instancing.

    ``compress`` (``EXT_meshopt_compression``) implies ``quantize``; the mesh returned is then
    in the compressed order (:func:`compression_ordered`).
    """
    mesh = terrain_mesh(heightmap, triangles, skirt=skirt)
    if compress:
        quantize = True
        mesh = compression_ordered(mesh)
    colour = bake_texture(heightmap, sun=sun, max_size=texture_size) if texture else None
    normals = None
    if normal_map:
        from terrascape.lighting import tangent_space_normals

        n = tangent_space_normals(heightmap)
        normals = np.rint((n.astype(np.float64) * 0.5 + 0.5) * 255).clip(0, 255).astype(np.uint8)
    extras, translation = _georeference(heightmap)
    doc = glb_document(mesh, base_colour=colour, normal_texture=normals, quantize=quantize,
                       compress=compress, split_uint16=split_uint16, extras=extras,
                       root_translation=translation if georeference_node else None)
    if objects is not None:  # terrascape.objects.Instances, one instanced node per mesh
        from terrascape.export.instances import add_instancing

        add_instancing(doc, objects)
    return glb_bytes(doc), mesh


def write_terrain_glb(
    heightmap: Heightmap,
    path: str | os.PathLike,
    *,
    max_error: float | None = None,
    max_triangles: int | None = None,
    force: bool = False,
    mesher: str | None = None,
    **options,
) -> tuple[Path, TerrainMesh]:
    """Mesh ``heightmap`` (any rectangular size) with the static mesher ``mesher``
    (:data:`terrascape.lod.static_meshers.STATIC_MESHERS`; ``None``: the default, RTIN)
    and write a textured GLB atomically.

    ``options`` are those of :func:`build_glb`. Returns the path and the mesh written.
    """
    if max_error is None and max_triangles is None:
        raise InvalidParameterError("give max_error (world units) and/or max_triangles")
    tri = static_mesher(mesher).mesh(heightmap, max_error=max_error, max_triangles=max_triangles)
    # the mesh's size is known only now: refused before the glb is built
    check_triangles(len(tri), ".glb", "a glb of a mesh of")
    data, mesh = build_glb(heightmap, tri, **options)
    with atomic_output(path, force=force) as tmp:
        Path(tmp).write_bytes(data)
    return Path(path), mesh
