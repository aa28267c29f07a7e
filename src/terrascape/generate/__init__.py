"""Heightmap generators: diamond-square (and Miller's square-square), fault formation, cosine
hills and tileable gradient-noise fBm / ridged multifractal.

:mod:`terrascape.generate.registry` lists them by name with typed parameters and defaults;
``generate("fbm", 513, seed=1)`` is what the command line, the viewer and the benchmarks
call. Each generator's module (and its numba kernels) is imported when first named
(:mod:`terrascape._lazy`), so ``terrascape generate fbm`` loads no other generator.
"""

from __future__ import annotations

from terrascape._lazy import lazy_exports

TYPE_CHECKING = False
if TYPE_CHECKING:
    from terrascape.generate.diamond_square import (
        DECAY_LAWS,
        detail_depth,
        diamond_square,
        roughness_schedule,
    )
    from terrascape.generate.fault import FALLOFFS, fault_formation
    from terrascape.generate.hills import hills
    from terrascape.generate.noise import fbm, gradient_noise, ridged
    from terrascape.generate.registry import GENERATORS, generate, generator_names, get_generator
    from terrascape.generate.square_square import square_square

__getattr__, __dir__ = lazy_exports(__name__, {
    "diamond_square": ("DECAY_LAWS", "detail_depth", "diamond_square", "roughness_schedule"),
    "fault": ("FALLOFFS", "fault_formation"),
    "hills": ("hills",),
    "noise": ("fbm", "gradient_noise", "ridged"),
    "registry": ("GENERATORS", "generate", "generator_names", "get_generator"),
    "square_square": ("square_square",),
})

__all__ = [
    "DECAY_LAWS",
    "FALLOFFS",
    "GENERATORS",
    "detail_depth",
    "diamond_square",
    "fault_formation",
    "fbm",
    "generate",
    "generator_names",
    "get_generator",
    "gradient_noise",
    "hills",
    "ridged",
    "roughness_schedule",
    "square_square",
]
