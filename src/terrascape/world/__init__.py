"""Worlds bigger than memory: chunked, resumable builds on dask.distributed into zarr.

The names are imported on first use (:mod:`terrascape._lazy`): the modules that need no
dask or zarr — the chunked level of detail of :mod:`terrascape.world.chunked_lod` — import
without the world extra installed.
"""

from __future__ import annotations

from terrascape._lazy import lazy_exports

TYPE_CHECKING = False
if TYPE_CHECKING:
    from terrascape.world.build import BuildResult, build_world, connect
    from terrascape.world.recipe import Recipe, load_recipe, recipe_from_dict
    from terrascape.world.store import open_world, world_info

__getattr__, __dir__ = lazy_exports(__name__, {
    "build": ("BuildResult", "build_world", "connect"),
    "recipe": ("Recipe", "load_recipe", "recipe_from_dict"),
    "store": ("open_world", "world_info"),
})

__all__ = ["BuildResult", "Recipe", "build_world", "connect", "load_recipe", "open_world",
           "recipe_from_dict", "world_info"]
