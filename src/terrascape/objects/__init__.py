"""Objects on the terrain: meshes, their instances, scattering by rules."""

from terrascape.objects.model import Instances, ObjectMesh

__all__ = ["Instances", "ObjectMesh"]
