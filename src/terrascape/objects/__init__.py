"""Objects on the terrain: meshes, their instances, scattering by rules."""

from terrascape.objects.gltf import load_gltf_copies, load_gltf_mesh
from terrascape.objects.load import load_objects, load_rules
from terrascape.objects.meshes import BUILTIN_NAMES, builtin_mesh, builtin_meshes
from terrascape.objects.model import Instances, ObjectMesh
from terrascape.objects.placement import instances_from_copies
from terrascape.objects.rules import (
    DEFAULT_MAX_OBJECTS,
    Band,
    RuleSet,
    ScatterRule,
    default_rules,
    default_tree_rule,
)
from terrascape.objects.scatter import scatter
from terrascape.objects.surface import surface_height, surface_normal

__all__ = [
    "BUILTIN_NAMES",
    "DEFAULT_MAX_OBJECTS",
    "Band",
    "Instances",
    "ObjectMesh",
    "RuleSet",
    "ScatterRule",
    "builtin_mesh",
    "builtin_meshes",
    "default_rules",
    "default_tree_rule",
    "instances_from_copies",
    "load_gltf_copies",
    "load_gltf_mesh",
    "load_objects",
    "load_rules",
    "scatter",
    "surface_height",
    "surface_normal",
]
