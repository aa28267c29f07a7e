"""``--objects SPEC``: the built-in set, a user's glTF model, or a rules file → instances.

``SPEC`` is one of

* ``default`` — the built-in meshes by the built-in rules
  (:func:`~terrascape.objects.rules.default_rules`);
* a ``.glb`` / ``.gltf`` file — the user's model, scattered by the default tree rule
  (:func:`~terrascape.objects.rules.default_tree_rule`); or, when the file places copies
  of its meshes (``EXT_mesh_gpu_instancing``, or one mesh drawn by several nodes), those
  copies where the file puts them, standing on the terrain
  (:mod:`terrascape.objects.placement`);
* a ``.toml`` / ``.json`` rules file (``docs/objects.md``): ``[[rules]]`` tables, optional
  ``sea_level`` and ``max_objects``, and an optional ``[meshes]`` table naming the user's glTF
  files (paths relative to the rules file) that the rules may use beside the built-in meshes.
"""

from __future__ import annotations

import json
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.objects.model import Instances
from terrascape.objects.rules import RuleSet, default_tree_rule, ruleset_from_dict
from terrascape.objects.scatter import scatter

__all__ = ["MODEL_SUFFIXES", "RULES_SUFFIXES", "load_objects", "load_rules", "read_masks"]

MODEL_SUFFIXES = (".glb", ".gltf")
RULES_SUFFIXES = (".toml", ".json")


def read_masks(folder: str | Path) -> dict[str, Any]:
    """The erosion masks ``flow``/``deposition``/``wear``/``water`` ``.npy`` found in
    ``folder`` (as ``terrascape erode --masks FOLDER`` writes them); at least one."""
    import numpy as np

    from terrascape.objects.rules import MASK_NAMES

    d = Path(folder)
    if not d.is_dir():
        raise FileFormatError(f"masks folder {d} does not exist")
    masks = {}
    for name in MASK_NAMES:
        file = d / f"{name}.npy"
        if file.is_file():
            try:
                masks[name] = np.load(file, allow_pickle=False)
            except (OSError, ValueError) as exc:
                raise FileFormatError(f"{file} is not a readable .npy file ({exc})") from None
    if not masks:
        raise FileFormatError(f"{d} holds none of {', '.join(f'{n}.npy' for n in MASK_NAMES)}")
    return masks


def load_rules(path: str | Path) -> RuleSet:
    """Read a rules file (TOML or JSON), loading the glTF models its ``[meshes]`` names."""
    from terrascape.objects.gltf import load_gltf_mesh

    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"rules file {p} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"cannot read the rules file {p}: {exc}") from None
    is_json = p.suffix.lower() == ".json"
    try:
        data = json.loads(text) if is_json else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise FileFormatError(
            f"rules file {p.name} is not valid {'JSON' if is_json else 'TOML'}: {exc}") from None
    if not isinstance(data, Mapping):
        raise FileFormatError(f"rules file {p.name} must hold a table at its top level")
    models = data.get("meshes", {})
    if not isinstance(models, Mapping):
        raise InvalidParameterError(f"{p.name}: [meshes] must be a table of name = \"file.glb\"")
    meshes = {}
    for name, file in models.items():
        if not isinstance(file, str) or Path(file).suffix.lower() not in MODEL_SUFFIXES:
            raise InvalidParameterError(
                f"{p.name}: meshes.{name} must name a .glb or .gltf file, got {file!r}")
        meshes[name] = load_gltf_mesh(p.parent / file, name=name)
    try:
        return ruleset_from_dict(data, meshes=meshes)
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"{p.name}: {exc}") from None


def load_objects(
    spec: str,
    heightmap: Heightmap,
    *,
    seed: int = 0,
    exaggeration: float = 1.0,
    masks: Mapping[str, Any] | None = None,
    sea_level: float | None = None,
    max_objects: int | None = None,
) -> Instances:
    """Resolve ``spec`` (see the module docstring) and scatter it on ``heightmap``.

    ``seed``, ``exaggeration``, ``masks``, ``sea_level`` and ``max_objects`` are those of
    :func:`~terrascape.objects.scatter.scatter` (``sea_level`` and ``max_objects`` override a
    rules file's).
    """
    if not isinstance(spec, str) or not spec.strip():
        raise InvalidParameterError("--objects needs 'default', a .glb/.gltf model or a "
                                    ".toml/.json rules file")
    kwargs = {"seed": seed, "exaggeration": exaggeration, "masks": masks,
              "sea_level": sea_level, "max_objects": max_objects}
    if spec == "default":
        return scatter(heightmap, None, **kwargs)
    suffix = Path(spec).suffix.lower()
    if suffix in MODEL_SUFFIXES:
        from terrascape.objects.gltf import load_gltf_copies, load_gltf_mesh, places_copies

        if places_copies(spec):  # the file says where its objects stand
            from terrascape.objects.placement import instances_from_copies

            return instances_from_copies(load_gltf_copies(spec), heightmap,
                                         exaggeration=exaggeration, max_objects=max_objects,
                                         source=Path(spec).name)
        mesh = load_gltf_mesh(spec)
        rule = default_tree_rule((mesh.name,))
        return scatter(heightmap, RuleSet((rule,), adapt_density=True),
                       meshes={mesh.name: mesh}, **kwargs)
    if suffix in RULES_SUFFIXES:
        return scatter(heightmap, load_rules(spec), **kwargs)
    raise InvalidParameterError(
        f"unknown --objects {spec!r}: give 'default', a .glb/.gltf model or a .toml/.json "
        "rules file")
