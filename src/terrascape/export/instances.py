"""Objects exported with the terrain: glTF GPU instancing, and instance lists for engines.

**glb** (``terrascape export blender --format glb``, ``export web``, ``terrascape mesh
x.glb``): :func:`add_instancing` adds each object mesh to the terrain's glTF document once
(``POSITION``, ``NORMAL``, linear ``COLOR_0``, a rough non-metallic material) and one node per
mesh carrying ``EXT_mesh_gpu_instancing`` with ``TRANSLATION``, ``ROTATION`` (unit quaternions
about +Y) and ``SCALE`` accessors — one draw per mesh in viewers that support it (three.js,
Babylon.js, Blender's importer, CesiumJS). As the extension's specification asks, it is
listed in ``extensionsRequired`` too (there is no fallback for viewers without it).

**Engines** (:func:`write_engine_instances`): ``NAME_objects.glb`` holds every mesh once,
at the origin, one node named after the mesh (import it as the prefabs / static meshes), and
``NAME_objects.json`` or ``NAME_objects.csv`` lists the instances in the engine's own axes and
units, placed on the terrain exactly as that destination's import instructions place it:

========  ======  =======================================================================
engine    file    position; rotation
========  ======  =======================================================================
unity     JSON    ``{"items": [{"mesh", "position": {"x","y","z"}, "rotationY", "scale"}]}``
                  — ``JsonUtility.FromJson`` reads it into ``[Serializable]`` classes;
                  metres, left-handed Y up, ``z = depth − z`` (Unity's terrain z = 0 is the
                  south edge); ``rotationY`` degrees, ``Quaternion.Euler(0, rotationY, 0)``
unreal    CSV     ``Name,Mesh,X,Y,Z,Yaw,Scale`` — a DataTable's CSV import (first column the
                  row name); centimetres, ``X = x``, ``Y = z`` (rows), ``Z = height``; Yaw
                  degrees (``FRotator(0, Yaw, 0)``)
godot     JSON    ``{"items": [{"mesh", "position": [x, y, z], "rotation_y", "scale"}]}`` —
                  ``JSON.parse_string``; the terrain's own axes (HTerrain at the origin);
                  ``rotation_y`` radians (``Node3D.rotation.y``)
blender   JSON    ``{"items": [{"mesh", "location": [x, y, z], "rotation_z", "scale"}]}`` —
                  Python's ``json``; Z up; for the TIFF displacement plane (centred at the
                  origin, its +Y edge north) ``x − width/2, depth/2 − z``; ``rotation_z``
                  radians (``object.rotation_euler.z``)
========  ======  =======================================================================

Every rotation is the same turn: the mesh's own +X axis ends where terrascape's yaw (counter-
clockwise seen from above about +Y, terrascape's x east and z south) puts it. The engine
lists are read back by :func:`read_engine_instances` and turned back into terrascape's frame by
:func:`engine_to_world` (what the tests check against the instances themselves).

References
----------
The Khronos Group, "EXT_mesh_gpu_instancing", glTF extension registry, 2021.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np

from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.model import Instances, ObjectMesh

__all__ = [
    "ENGINES",
    "INSTANCING",
    "OBJECT_DESTINATIONS",
    "add_instancing",
    "engine_to_world",
    "instances_json",
    "objects_for",
    "objects_glb",
    "read_engine_instances",
    "read_instances_json",
    "texture_shore",
    "world_to_engine",
    "write_engine_instances",
]

INSTANCING = "EXT_mesh_gpu_instancing"
#: Export destinations that carry objects (in their glb, or as an instance list).
OBJECT_DESTINATIONS = ("blender", "godot", "unity", "unreal", "web")
#: Engine → the instance-list file it reads most easily.
ENGINES = {"unity": "json", "unreal": "csv", "godot": "json", "blender": "json"}
_FLOAT, _UNSIGNED_INT = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def texture_shore(heightmap: Heightmap) -> float:
    """The height where the baked glb texture's water turns to sand (half-way through the
    blend of :func:`~terrascape.texture.default_regions`' water band): the sea level objects
    in a textured glb keep above by default."""
    from terrascape.texture import default_regions

    water = default_regions(heightmap)[0]
    return float(water.max + water.range / 2.0)


def objects_for(options, heightmap: Heightmap) -> Instances | None:
    """The objects an export carries: ``options.objects`` is ``None``, an :class:`Instances`
    already placed, or a callable placing them on the (fitted) heightmap being exported."""
    objects = getattr(options, "objects", None)
    if objects is None or isinstance(objects, Instances):
        return objects
    if callable(objects):
        placed = objects(heightmap)
        if not isinstance(placed, Instances):
            raise InvalidParameterError("the objects callable must return Instances")
        return placed
    raise InvalidParameterError(
        f"export objects must be Instances or a callable, got {type(objects).__name__}")


# --- glTF ------------------------------------------------------------------------------------
class _Blob:
    """Appends 4-byte aligned buffer views and accessors to a document's (new) binary chunk."""

    def __init__(self, doc, blob: bytes) -> None:
        self.doc = doc
        self.blob = bytearray(blob)

    def accessor(self, array: np.ndarray, component: int, kind: str, *,
                 target: int | None, bounds: bool = False) -> int:
        import pygltflib

        arr = np.ascontiguousarray(array)
        self.blob.extend(b"\x00" * ((-len(self.blob)) % 4))
        data = arr.astype(arr.dtype.newbyteorder("<")).tobytes()
        self.doc.bufferViews.append(pygltflib.BufferView(
            buffer=0, byteOffset=len(self.blob), byteLength=len(data), target=target))
        self.blob.extend(data)
        acc = pygltflib.Accessor(bufferView=len(self.doc.bufferViews) - 1, byteOffset=0,
                                 componentType=component, count=len(arr), type=kind)
        if bounds:
            flat = arr.reshape(len(arr), -1)
            cast = float if arr.dtype.kind == "f" else int
            acc.min = [cast(v) for v in flat.min(axis=0)]
            acc.max = [cast(v) for v in flat.max(axis=0)]
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1


def _add_mesh(doc, blob: _Blob, mesh: ObjectMesh, material: int) -> int:
    import pygltflib

    attrs = pygltflib.Attributes(
        POSITION=blob.accessor(mesh.positions, _FLOAT, "VEC3", target=_ARRAY_BUFFER,
                               bounds=True),
        NORMAL=blob.accessor(mesh.normals, _FLOAT, "VEC3", target=_ARRAY_BUFFER),
        COLOR_0=blob.accessor(mesh.colors, _FLOAT, "VEC3", target=_ARRAY_BUFFER))
    indices = blob.accessor(mesh.indices.reshape(-1), _UNSIGNED_INT, "SCALAR",
                            target=_ELEMENT_ARRAY_BUFFER, bounds=True)
    doc.meshes.append(pygltflib.Mesh(name=mesh.name, primitives=[pygltflib.Primitive(
        attributes=attrs, indices=indices, material=material, mode=pygltflib.TRIANGLES)]))
    return len(doc.meshes) - 1


def _object_material(doc) -> int:
    import pygltflib

    doc.materials.append(pygltflib.Material(
        name="objects", pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.9),
        doubleSided=False))
    return len(doc.materials) - 1


def _yaw_quaternions(yaw: np.ndarray) -> np.ndarray:
    """``(N, 4)`` float32 ``(x, y, z, w)``: a turn of ``yaw`` about +Y (right-handed)."""
    half = yaw.astype(np.float64) / 2.0
    q = np.zeros((len(yaw), 4))
    q[:, 1] = np.sin(half)
    q[:, 3] = np.cos(half)
    return q.astype(np.float32)


def add_instancing(doc, instances: Instances, *, parent: int = 0) -> list[int]:
    """Add ``instances`` to the glTF document ``doc`` (its binary blob is extended): each mesh
    with instances once, and a child of node ``parent`` per mesh with
    ``EXT_mesh_gpu_instancing``. Returns the new node indices."""
    import pygltflib

    if len(instances) == 0:
        return []
    blob = _Blob(doc, doc.binary_blob() or b"")
    material = _object_material(doc)
    nodes = []
    for k, mesh in enumerate(instances.meshes):
        sel = instances.of_kind(k)
        if len(sel) == 0:
            continue
        mesh_index = _add_mesh(doc, blob, mesh, material)
        scale = np.repeat(instances.scale[sel][:, None], 3, axis=1)
        attributes = {
            "TRANSLATION": blob.accessor(instances.positions[sel], _FLOAT, "VEC3",
                                         target=None, bounds=True),
            "ROTATION": blob.accessor(_yaw_quaternions(instances.yaw[sel]), _FLOAT, "VEC4",
                                      target=None),
            "SCALE": blob.accessor(scale.astype(np.float32), _FLOAT, "VEC3", target=None),
        }
        doc.nodes.append(pygltflib.Node(name=f"{mesh.name} ×{len(sel)}", mesh=mesh_index,
                                        extensions={INSTANCING: {"attributes": attributes}}))
        nodes.append(len(doc.nodes) - 1)
    root = doc.nodes[parent]
    root.children = list(root.children or []) + nodes
    for key in ("extensionsUsed", "extensionsRequired"):
        names = list(getattr(doc, key) or [])
        if INSTANCING not in names:
            names.append(INSTANCING)
        setattr(doc, key, names)
    if not doc.buffers:
        doc.buffers = [pygltflib.Buffer(byteLength=0)]
    doc.buffers[0].byteLength = len(blob.blob)
    doc.set_binary_blob(bytes(blob.blob))
    return nodes


def objects_glb(meshes) -> bytes:
    """A glb with each mesh once at the origin, one node per mesh named after it (the
    prefabs / static meshes an engine's instance list refers to)."""
    import pygltflib

    doc = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="terrascape"))
    blob = _Blob(doc, b"")
    material = _object_material(doc)
    for mesh in meshes:
        doc.nodes.append(pygltflib.Node(name=mesh.name, mesh=_add_mesh(doc, blob, mesh,
                                                                       material)))
    doc.scenes = [pygltflib.Scene(nodes=list(range(len(doc.nodes))))]
    doc.scene = 0
    doc.buffers = [pygltflib.Buffer(byteLength=len(blob.blob))]
    doc.set_binary_blob(bytes(blob.blob))
    return b"".join(doc.save_to_bytes())


# --- engine axes ------------------------------------------------------------------------------
def _check_engine(engine: str) -> str:
    if engine not in ENGINES:
        raise InvalidParameterError(f"no instance list for {engine!r}; engines: "
                                    f"{', '.join(ENGINES)}")
    return engine


def world_to_engine(engine: str, heightmap: Heightmap, positions: np.ndarray,
                    yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions ``(N, 3)`` and rotations ``(N,)`` in ``engine``'s axes, units and angle
    convention (see the module docstring) — float64."""
    _check_engine(engine)
    p = np.asarray(positions, np.float64)
    y = np.asarray(yaw, np.float64)
    ex, ez = heightmap.extent
    x, h, z = p[:, 0], p[:, 1], p[:, 2]
    if engine == "unity":
        return np.stack([x, h, ez - z], 1), -np.degrees(y)
    if engine == "unreal":
        return np.stack([x, z, h], 1) * 100.0, -np.degrees(y)
    if engine == "godot":
        return p.copy(), y.copy()
    return np.stack([x - ex / 2.0, ez / 2.0 - z, h], 1), y.copy()  # blender


def engine_to_world(engine: str, heightmap: Heightmap, positions: np.ndarray,
                    rotation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The inverse of :func:`world_to_engine` (yaw wrapped to [0, 2π))."""
    _check_engine(engine)
    p = np.asarray(positions, np.float64)
    r = np.asarray(rotation, np.float64)
    ex, ez = heightmap.extent
    if engine == "unity":
        world, yaw = np.stack([p[:, 0], p[:, 1], ez - p[:, 2]], 1), -np.radians(r)
    elif engine == "unreal":
        q = p / 100.0
        world, yaw = np.stack([q[:, 0], q[:, 2], q[:, 1]], 1), -np.radians(r)
    elif engine == "godot":
        world, yaw = p.copy(), r.copy()
    else:
        world, yaw = np.stack([p[:, 0] + ex / 2.0, p[:, 2], ez / 2.0 - p[:, 1]], 1), r.copy()
    return world, np.mod(yaw, 2.0 * math.pi)


def _num(v: float) -> float:
    """Shortest decimal that reads back to the same float32 (small, exact files)."""
    return float(str(np.float32(v)))


def _instance_list(engine: str, heightmap: Heightmap, instances: Instances) -> str:
    pos, rot = world_to_engine(engine, heightmap, instances.positions, instances.yaw)
    names = [instances.meshes[int(k)].name for k in instances.kind]
    scale = instances.scale
    if engine == "unreal":
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["Name", "Mesh", "X", "Y", "Z", "Yaw", "Scale"])
        for i in range(len(instances)):
            w.writerow([f"obj{i}", names[i], *(_num(v) for v in pos[i]), _num(rot[i]),
                        _num(scale[i])])
        return buf.getvalue()
    items = []
    for i in range(len(instances)):
        x, y, z = (_num(v) for v in pos[i])
        if engine == "unity":
            items.append({"mesh": names[i], "position": {"x": x, "y": y, "z": z},
                          "rotationY": _num(rot[i]), "scale": _num(scale[i])})
        elif engine == "godot":
            items.append({"mesh": names[i], "position": [x, y, z], "rotation_y": _num(rot[i]),
                          "scale": _num(scale[i])})
        else:
            items.append({"mesh": names[i], "location": [x, y, z], "rotation_z": _num(rot[i]),
                          "scale": _num(scale[i])})
    return json.dumps({"items": items}, separators=(",", ":")) + "\n"


def read_engine_instances(engine: str, path: str | Path) -> dict[str, np.ndarray]:
    """An engine instance list read back: ``{"mesh": names, "position": (N, 3),
    "rotation": (N,), "scale": (N,)}`` in the engine's own convention."""
    _check_engine(engine)
    text = Path(path).read_text(encoding="utf-8")
    if engine == "unreal":
        rows = list(csv.DictReader(io.StringIO(text)))
        return {"mesh": np.array([r["Mesh"] for r in rows]),
                "position": np.array([[float(r[k]) for k in "XYZ"] for r in rows]).reshape(-1, 3),
                "rotation": np.array([float(r["Yaw"]) for r in rows]),
                "scale": np.array([float(r["Scale"]) for r in rows])}
    items = json.loads(text)["items"]
    if engine == "unity":
        pos = [[it["position"][k] for k in "xyz"] for it in items]
        rot = [it["rotationY"] for it in items]
    elif engine == "godot":
        pos = [it["position"] for it in items]
        rot = [it["rotation_y"] for it in items]
    else:
        pos = [it["location"] for it in items]
        rot = [it["rotation_z"] for it in items]
    return {"mesh": np.array([it["mesh"] for it in items]),
            "position": np.array(pos, np.float64).reshape(-1, 3),
            "rotation": np.array(rot, np.float64), "scale": np.array([it["scale"] for it in items],
                                                                    np.float64)}


_HOW = {
    "unity": ["Import {glb} (glTFast or UnityGLTF); one prefab per child named after its mesh.",
              "Read {list} with JsonUtility.FromJson<List>(text) where",
              "  [Serializable] class Item {{ public string mesh; public Vector3 position; "
              "public float rotationY; public float scale; }}",
              "  [Serializable] class List {{ public Item[] items; }}",
              "and Instantiate(prefab[mesh], position, Quaternion.Euler(0, rotationY, 0)) with "
              "localScale = Vector3.one * scale (the terrain at the position its import notes "
              "give; heights are world Y)."],
    "unreal": ["Import {glb} (Interchange glTF) as static meshes named after the meshes.",
               "{list}: a DataTable CSV (row struct: Mesh Name, X, Y, Z, Yaw, Scale floats), "
               "or read it in an editor Python script; centimetres, the landscape's X/Y with "
               "Z = height; spawn with FRotator(0, Yaw, 0) (Instanced / Foliage components "
               "draw many cheaply)."],
    "godot": ["Import {glb}; each child is named after its mesh (a MultiMeshInstance3D per mesh "
              "draws many cheaply).",
              "{list}: JSON.parse_string(text).items; each item: position [x, y, z] in the "
              "terrain's frame (HTerrain at the origin), rotation_y radians, scale uniform."],
    "blender": ["File > Import > glTF 2.0 > {glb} (one object per mesh, at the origin).",
                "{list}: json.load(open(path))['items']; location [x, y, z] (Z up, metres) on "
                "the plane the TIFF import notes build (centred at the origin, +Y north); "
                "rotation_euler.z = rotation_z; scale uniform. Link-duplicate "
                "(bpy.data.objects.new(name, mesh_object.data)) for instances."],
}


def write_engine_instances(engine: str, heightmap: Heightmap, out_dir: Path, name: str,
                           options) -> list[Path]:
    """The hook of the engine exporters: ``[]`` when the export carries no objects, else the
    files written (``NAME_objects.glb``, the instance list, ``NAME_objects_import.txt``)."""
    from terrascape.export._common import write_bytes, write_text

    instances = objects_for(options, heightmap)
    if instances is None:
        return []
    _check_engine(engine)
    out = Path(out_dir)
    used = sorted({int(k) for k in instances.kind})
    glb = write_bytes(out / f"{name}_objects.glb",
                      objects_glb([instances.meshes[k] for k in used] or instances.meshes),
                      force=options.force)
    listing = write_text(out / f"{name}_objects.{ENGINES[engine]}",
                         _instance_list(engine, heightmap, instances), force=options.force)
    counts = {}
    for k in instances.kind:
        counts[instances.meshes[int(k)].name] = counts.get(instances.meshes[int(k)].name, 0) + 1
    lines = [f"Objects on {name} for {engine} (written by terrascape)", "",
             f"{len(instances)} objects: " + ", ".join(f"{n} {c}" for n, c in counts.items()), ""]
    lines += [line.format(glb=glb.name, list=listing.name) for line in _HOW[engine]]
    note = write_text(out / f"{name}_objects_import.txt", "\n".join(lines) + "\n",
                      force=options.force)
    return [glb, listing, note]


# --- terrascape's own list ------------------------------------------------------------------
def instances_json(instances: Instances, heightmap: Heightmap | None = None) -> str:
    """The instances as terrascape's JSON instance list (``terrascape objects scatter``):
    ``{"axes", "meshes", "rules", "counts", "instances": [{"mesh", "x", "y", "z", "yaw",
    "scale"}]}`` in the terrain's world frame (x east, y up, z south, world units; yaw radians
    counter-clockwise seen from above). Numbers are the shortest decimals that read back to
    the stored float32 values."""
    counts: dict[str, int] = {m.name: 0 for m in instances.meshes}
    records = []
    for i in range(len(instances)):
        mesh = instances.meshes[int(instances.kind[i])].name
        counts[mesh] += 1
        x, y, z = (_num(v) for v in instances.positions[i])
        records.append({"mesh": mesh, "x": x, "y": y, "z": z, "yaw": _num(instances.yaw[i]),
                        "scale": _num(instances.scale[i])})
    meta = instances.metadata
    doc = {
        "generator": "terrascape",
        "axes": "x east, y up, z south (rows), world units; yaw radians counter-clockwise "
                "seen from above; each object's foot at (x, y, z)",
        "count": len(instances),
        "counts": counts,
        "meshes": {m.name: f"{m.triangles} triangles, "
                           + " × ".join(f"{v:.3g}" for v in m.bounds[1] - m.bounds[0])
                           + " (x × y × z)" for m in instances.meshes},
        "rules": meta.get("rules", []),
        "seed": meta.get("seed"),
        "exaggeration": meta.get("exaggeration", 1.0),
    }
    if heightmap is not None:
        doc["terrain"] = {"samples": [heightmap.cols, heightmap.rows],
                          "spacing": list(heightmap.spacing),
                          "extent": list(heightmap.extent)}
    # the header readable, then one line per object (a list of 200 000 stays greppable)
    head = json.dumps(doc, indent=1, ensure_ascii=False)
    body = ",\n".join("  " + json.dumps(r, ensure_ascii=False) for r in records)
    return f'{head[:-2]},\n "instances": [\n{body}\n ]\n}}\n'



def read_instances_json(path: str | Path) -> dict:
    """A list written by :func:`instances_json` as ``{"mesh": names, "positions": (N, 3),
    "yaw": (N,), "scale": (N,), ...the other keys}`` (float64 arrays)."""
    from terrascape.errors import FileFormatError

    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
        rec = doc["instances"]
        out = {k: v for k, v in doc.items() if k != "instances"}
        out["mesh"] = np.array([r["mesh"] for r in rec])
        out["positions"] = np.array([[r["x"], r["y"], r["z"]] for r in rec],
                                    np.float64).reshape(-1, 3)
        out["yaw"] = np.array([r["yaw"] for r in rec], np.float64)
        out["scale"] = np.array([r["scale"] for r in rec], np.float64)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise FileFormatError(f"{path}: not a terrascape instance list ({exc})") from None
    return out
