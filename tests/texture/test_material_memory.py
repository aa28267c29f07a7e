"""Built-in materials are built in blocks of rows: the same bytes as one whole-image pass,
and a peak traced memory of a few times the uint8 texture (it was about 29×)."""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest

from terrascape.texture._noise import PeriodicFbm, periodic_fbm
from terrascape.texture.materials import BUILTIN_MATERIALS, builtin_material

materials = importlib.import_module("terrascape.texture.materials")


@pytest.mark.parametrize("name", BUILTIN_MATERIALS)
def test_blocks_give_the_same_bytes(name: str, monkeypatch) -> None:
    materials._cached_material.cache_clear()
    whole = builtin_material(name, 48, seed=3)
    monkeypatch.setattr(materials, "_BLOCK_PIXELS", 48 * 5)  # 5 rows a block, last short
    materials._cached_material.cache_clear()
    try:
        assert np.array_equal(builtin_material(name, 48, seed=3), whole)
    finally:
        materials._cached_material.cache_clear()


def test_fbm_rows_are_rows_of_the_whole_image() -> None:
    whole = periodic_fbm(40, (3, 3), np.random.default_rng(1), octaves=3, ridged=True)
    fbm = PeriodicFbm(40, (3, 3), np.random.default_rng(1), octaves=3, ridged=True)
    assert np.array_equal(np.vstack([fbm.rows(0, 13), fbm.rows(13, 40)]), whole)


@pytest.mark.parametrize("name", ["rock", "grass"])
def test_peak_is_a_few_times_the_texture(name: str) -> None:
    materials._cached_material.cache_clear()
    tracemalloc.start()
    try:
        img = builtin_material(name, 1024, seed=11)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
        materials._cached_material.cache_clear()
    # The cached texture and the caller's copy are 2×; the bound leaves room for one block.
    assert peak <= 4.0 * img.nbytes, f"peak {peak / img.nbytes:.1f}× the texture"
