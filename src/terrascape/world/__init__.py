"""Worlds bigger than memory: chunked, resumable builds on dask.distributed into zarr."""

from terrascape.world.build import BuildResult, build_world, connect
from terrascape.world.recipe import Recipe, load_recipe, recipe_from_dict
from terrascape.world.store import open_world, world_info

__all__ = ["BuildResult", "Recipe", "build_world", "connect", "load_recipe", "open_world",
           "recipe_from_dict", "world_info"]
