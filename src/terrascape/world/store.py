"""The world store: one zarr group (``world.zarr``) holding every array of a world.

Layout::

    height          float32 (rows, cols), chunk × chunk
    bounds          float32 (chunk rows, chunk cols, 2): min and max height of each chunk
                    (frustum culling and the shadow halo read these, not the heights)
    height_raw      float32, the generator's heights before erosion (with [erosion]/[thermal])
    droplet_window  float64 (chunk rows, chunk cols, W, W): each chunk's window of
                    W = chunk + 2 · halo samples after its droplet phase (droplet [erosion])
    height_eroded   float32, after [erosion], before [thermal] (with both)
    normals         float32 (rows, cols, 3), world-space unit normals, Y up
    shadow          uint8 (rows, cols), 1 = in shadow
    levels/1 … k    float32, level k + 1 = every other sample of level k (level 0 = height)
    done/<array>    uint8 (chunk rows, chunk cols): 1 where that chunk is finished

Attributes: ``terrascape_world`` (format version), ``recipe`` (canonical JSON),
``recipe_hash`` (its SHA-256), ``spacing``, ``seed``, ``shape``, ``chunk``, ``levels`` and
``complete``. A store is only ever continued with the recipe that made it.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import zarr

from terrascape.errors import FileFormatError, OutputExistsError
from terrascape.world.recipe import Recipe, erosion_halo, recipe_from_dict

FORMAT_VERSION = 1


def level_shapes(recipe: Recipe) -> list[tuple[int, int]]:
    """Shapes of ``levels/1 … k``: halve (every other sample) until the side fits a chunk."""
    shapes = []
    rows, cols = recipe.shape
    while max(rows, cols) > recipe.chunk:
        rows, cols = (rows + 1) // 2, (cols + 1) // 2
        shapes.append((rows, cols))
    return shapes


def array_specs(recipe: Recipe) -> dict[str, tuple[tuple[int, ...], tuple[int, ...], Any]]:
    """``name -> (shape, chunks, dtype)`` of every array, in build order."""
    c = recipe.chunk
    specs: dict[str, tuple[tuple[int, ...], tuple[int, ...], Any]] = {}
    if recipe.thermal is not None or recipe.erosion is not None:
        specs["height_raw"] = (recipe.shape, (c, c), np.float32)
    if recipe.erosion is not None and recipe.erosion["model"] == "droplets":
        # Each chunk's float64 window (chunk + halo on every side) after its droplet phase.
        w = c + 2 * erosion_halo(recipe.erosion)
        specs["droplet_window"] = ((*chunk_grid(recipe.shape, c), w, w), (1, 1, w, w),
                                   np.float64)
    if recipe.thermal is not None and recipe.erosion is not None:
        specs["height_eroded"] = (recipe.shape, (c, c), np.float32)
    specs["height"] = (recipe.shape, (c, c), np.float32)
    specs["bounds"] = ((*chunk_grid(recipe.shape, c), 2), (1, 1, 2), np.float32)
    if recipe.normals is not None:
        specs["normals"] = ((*recipe.shape, 3), (c, c, 3), np.float32)
    if recipe.shadow is not None:
        specs["shadow"] = (recipe.shape, (c, c), np.uint8)
    for k, shape in enumerate(level_shapes(recipe), start=1):
        specs[f"levels/{k}"] = (shape, (c, c), np.float32)
    return specs


def chunk_grid(shape: tuple[int, ...], chunk: int) -> tuple[int, int]:
    return (-(-shape[0] // chunk), -(-shape[1] // chunk))


def task_grid(name: str, recipe: Recipe) -> tuple[int, int]:
    """Tasks (one per chunk of the heights) that build array ``name``."""
    shape = array_specs(recipe)[name][0]
    per_chunk = name in ("bounds", "droplet_window")
    return chunk_grid(recipe.shape if per_chunk else shape, recipe.chunk)


def is_world(path: str | Path) -> bool:
    """Whether ``path`` is a terrascape world store (a zarr group with world attributes)."""
    p = Path(path)
    if not (p.is_dir() and (p / "zarr.json").is_file()):
        return False
    return _is_world(p)


def _is_world(path: Path) -> bool:
    try:
        return "terrascape_world" in zarr.open_group(str(path), mode="r").attrs
    except Exception:  # anything that is not a readable zarr group
        return False


def create_or_resume(path: str | Path, recipe: Recipe, *, force: bool = False) -> zarr.Group:
    """Open the store at ``path`` to build ``recipe`` into, creating it when needed.

    A store made by the same recipe is resumed (its finished chunks are kept); one made by
    another recipe, or anything else at ``path``, is refused unless ``force`` (then replaced).
    A new store is made in a hidden folder next to ``path`` and renamed into place once its
    arrays and recipe are written: a store interrupted while it is made leaves nothing, and
    when another build made the same store meanwhile, that one is resumed.
    """
    p = Path(path)
    if p.exists():
        if _is_world(p):
            group = zarr.open_group(str(p), mode="r+")
            theirs = group.attrs.get("recipe_hash")
            if theirs == recipe.digest():
                _add_missing_arrays(group, recipe)
                return group
            if not force:
                raise OutputExistsError(
                    f"{p} holds a world built from another recipe (hash {str(theirs)[:12]}…, "
                    f"this recipe {recipe.digest()[:12]}…): never mixed; use --force to "
                    "replace it or another output path")
        elif not force:
            raise OutputExistsError(f"{p} exists and is not a terrascape world; use --force "
                                    "to replace it")
        if p.is_dir():
            shutil.rmtree(p)
        else:
            p.unlink()
    p.parent.mkdir(parents=True, exist_ok=True)
    made = Path(tempfile.mkdtemp(prefix=f".{p.name[:40]}.", suffix=".part", dir=p.parent))
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(made, 0o777 & ~mask)  # a folder's usual permissions, not mkdtemp's 0700
        group = zarr.open_group(str(made), mode="w")
        _add_missing_arrays(group, recipe)
        group.attrs.update({
            "terrascape_world": FORMAT_VERSION,
            "recipe": recipe.canonical_json(),
            "recipe_hash": recipe.digest(),
            "spacing": recipe.spacing,
            "seed": recipe.seed,
            "shape": list(recipe.shape),
            "chunk": recipe.chunk,
            "levels": len(level_shapes(recipe)),
            "complete": False,
        })
        try:
            os.rename(made, p)
        except OSError as exc:
            if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY):
                raise
            # another build made the store meanwhile: resume it (or refuse it) as above
            return create_or_resume(p, recipe)
    finally:
        shutil.rmtree(made, ignore_errors=True)
    return zarr.open_group(str(p), mode="r+")


def _add_missing_arrays(group: zarr.Group, recipe: Recipe) -> None:
    """Create every array of the recipe's layout the store lacks (all of them in a new
    store; in a store of an older layout, the arrays added since, to be built on resume)."""
    for name, (shape, chunks, dtype) in array_specs(recipe).items():
        if name in group:
            continue
        group.create_array(name, shape=shape, chunks=chunks, dtype=dtype, fill_value=0)
        group.create_array(f"done/{name}", shape=task_grid(name, recipe), chunks=(1, 1),
                           dtype=np.uint8, fill_value=0)
        group.attrs["complete"] = False


@dataclass(frozen=True)
class WorldInfo:
    path: Path
    recipe: Recipe
    arrays: dict[str, tuple[tuple[int, ...], tuple[int, ...], str, int, int]]
    complete: bool

    def lines(self) -> list[str]:
        r = self.recipe
        out = [f"world {self.path}: {r.rows} rows × {r.cols} cols, spacing {r.spacing:g}, "
               f"seed {r.seed}, chunk {r.chunk}, {'complete' if self.complete else 'INCOMPLETE'}"]
        for name, (shape, chunks, dtype, done, total) in self.arrays.items():
            out.append(f"  {name:<14} {dtype:<8} {' × '.join(map(str, shape)):<20} chunks "
                       f"{'×'.join(map(str, chunks))}  done {done}/{total}")
        out.append(f"  recipe {self.recipe.canonical_json()}")
        return out


def open_world(path: str | Path) -> tuple[zarr.Group, Recipe]:
    """A finished or partial world store and the recipe it was built from."""
    p = Path(path)
    if not p.exists():
        raise FileFormatError(f"{p} does not exist")
    if not _is_world(p):
        raise FileFormatError(f"{p} is not a terrascape world (no world attributes)")
    group = zarr.open_group(str(p), mode="r")
    return group, recipe_from_dict(json.loads(group.attrs["recipe"]))


def world_info(path: str | Path) -> WorldInfo:
    group, recipe = open_world(path)
    arrays = {}
    for name, (shape, chunks, dtype) in array_specs(recipe).items():
        done = np.asarray(group[f"done/{name}"][...])
        arrays[name] = (shape, chunks, np.dtype(dtype).name, int(done.sum()), int(done.size))
    return WorldInfo(Path(path), recipe, arrays, bool(group.attrs.get("complete", False)))


__all__ = ["array_specs", "chunk_grid", "create_or_resume", "is_world", "level_shapes",
           "open_world", "task_grid", "world_info"]
