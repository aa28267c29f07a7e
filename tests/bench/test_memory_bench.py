"""``bench memory`` measures what a job allocates: the traced peak covers the result and
its temporaries, and the caches are cleared so a cached texture is not measured as free."""

from __future__ import annotations

import numpy as np

from terrascape.bench import available_cases
from terrascape.bench.memory import _clear_texture_caches, traced_peak
from terrascape.texture.materials import _cached_material, builtin_material


def test_memory_is_a_bench_case() -> None:
    assert "memory" in available_cases()


def test_peak_counts_the_result_and_its_temporaries() -> None:
    def job() -> np.ndarray:
        scratch = np.ones(1_000_000)  # 8 MB, freed before returning
        return np.zeros(250_000, dtype=np.float32) + np.float32(scratch[:4].sum())

    peak, result = traced_peak(job)
    assert result.nbytes == 1_000_000
    assert peak >= 8_000_000 + result.nbytes


def test_texture_caches_are_cleared_around_the_run() -> None:
    builtin_material("sand", 64, seed=4)
    assert _cached_material.cache_info().currsize >= 1
    peak, img = traced_peak(lambda: builtin_material("sand", 64, seed=4), _clear_texture_caches)
    assert _cached_material.cache_info().currsize == 0
    assert peak >= 2 * img.nbytes  # built, cached and copied: not a cache hit
