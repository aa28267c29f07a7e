"""``terrascape bench memory``: peak memory of the generators, the textures and
``height_from_image``, as a multiple of the result's size.

Each job runs once to compile its kernels and fill no cache that it would reuse (caches are
cleared before every measured run), then once under :mod:`tracemalloc`, which counts every
numpy allocation (not the small per-row buffers inside numba kernels, nor the interpreter).
The figure is the traced peak divided by the bytes of the array returned: 1× is the result
alone. Targets: generators ≤ 2×, textures ≤ 4× (``height_from_image`` ≤ 4× as well).
"""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable

import numpy as np

from terrascape.bench import BenchTable

GENERATOR_TARGET = 2.0
TEXTURE_TARGET = 4.0


def traced_peak(job: Callable[[], np.ndarray], clear: Callable[[], None] = lambda: None
                ) -> tuple[float, np.ndarray]:
    """``(peak bytes, result)`` of one run of ``job`` under tracemalloc, after ``clear()``."""
    clear()
    tracemalloc.start()
    try:
        result = job()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    clear()
    return float(peak), result


def _clear_texture_caches() -> None:
    from terrascape.texture import materials, photo_materials

    materials._cached_material.cache_clear()
    photo_materials._cached_layers.cache_clear()


def _row(table: BenchTable, what: str, size: str, job: Callable[[], np.ndarray],
         target: float | None, clear: Callable[[], None] = lambda: None) -> None:
    job()  # compile and warm up
    peak, result = traced_peak(job, clear)
    ratio = peak / result.nbytes
    table.rows.append([what, size, str(result.dtype), result.nbytes / 2**20, peak / 2**20,
                       ratio])
    if target is not None:
        table.check_target(f"{what} {size}", ratio, at_most=target, unit="×")


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.generate.registry import generate, generator_names
    from terrascape.lighting.height_from_image import height_from_image
    from terrascape.texture import builtin_material, region_texture
    from terrascape.texture.materials import BUILTIN_MATERIALS
    from terrascape.texture.photo_materials import photo_material
    from terrascape.texture.terrain_material import material_texture

    n = 513 if quick else 2049
    side = 512 if quick else 2048
    columns = ["job", "size", "result", "result MiB", "peak MiB", "peak ÷ result"]
    gens = BenchTable(f"Generators: traced peak memory at {n}² (float32 heights)", columns)
    for name in generator_names():
        _row(gens, name, f"{n}²", lambda name=name: generate(name, n, seed=1).heights,
             GENERATOR_TARGET)
    gens.notes.append(f"target: ≤ {GENERATOR_TARGET:g}× the heights")

    tex = BenchTable(f"Textures and height from image: traced peak memory at {side}²", columns)
    for name in BUILTIN_MATERIALS:
        _row(tex, f"material {name}", f"{side}²",
             lambda name=name: builtin_material(name, side, seed=1), TEXTURE_TARGET,
             _clear_texture_caches)
    _row(tex, "material photo-rock", f"{side}²", lambda: photo_material("rock", side, seed=1),
         TEXTURE_TARGET, _clear_texture_caches)
    hm = generate("fbm", side + 1, seed=1)
    _row(tex, "regions (scale 1)", f"{side + 1}²", lambda: region_texture(hm, seed=1),
         TEXTURE_TARGET, _clear_texture_caches)
    _row(tex, "terrain material (scale 1)", f"{side + 1}²",
         lambda: material_texture(hm, seed=1), TEXTURE_TARGET, _clear_texture_caches)
    photo = np.random.default_rng(1).integers(0, 256, (side, side, 3), dtype=np.uint8)
    _row(tex, "height_from_image", f"{side}² RGB",
         lambda: height_from_image(photo), TEXTURE_TARGET)
    _row(tex, "height_from_image --blur 2", f"{side}² RGB",
         lambda: height_from_image(photo, blur_sigma=2.0), TEXTURE_TARGET)
    tex.notes += [
        f"target: ≤ {TEXTURE_TARGET:g}× the result (uint8 RGB textures, float32 heights)",
        "built-in materials are cached: the cached texture and the caller's copy are 2×",
        "the input photo of height_from_image exists before the run and is not counted",
        "photo and terrain materials are made in blocks of rows; their fixed part (the "
        "512² source photo's Fourier block, the 256² layers) is 10–25 MiB, so the ratio "
        "is for the full run's 2048² (at --quick's 512² the fixed part dominates)",
    ]
    return [gens, tex]


__all__ = ["run", "traced_peak"]
