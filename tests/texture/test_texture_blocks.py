"""The photo materials and the terrain material are computed in blocks of rows: the same
bytes as the whole-image computation they replace, exact global percentiles from blocks, and
a peak traced memory of a few times the image (it was 68× for a photo material and 85× for
the terrain material)."""

from __future__ import annotations

import importlib
import tracemalloc

import numpy as np
import pytest
from scipy import ndimage

from terrascape.generate.registry import generate
from terrascape.heightmap import Heightmap
from terrascape.texture._block_percentile import block_percentiles
from terrascape.texture._noise import periodic_fbm
from terrascape.texture.photo_materials import (
    _RECIPES,
    MATERIAL_LAYERS,
    layer_spectrum_bytes,
    periodic_component,
    photo_material,
    photo_material_layers,
)

photo_materials = importlib.import_module("terrascape.texture.photo_materials")
terrain_material = importlib.import_module("terrascape.texture.terrain_material")


# --- the whole-image photo layer, as it was computed before the blocks ------------------------
def _fourier_resize(image: np.ndarray, size: int) -> np.ndarray:
    m = image.shape[0]
    spec = np.fft.fftshift(np.fft.fft2(image))
    out = np.zeros((size, size), dtype=complex)
    k = min(m, size)
    so, si = (size - k) // 2, (m - k) // 2
    out[so:so + k, so:so + k] = spec[si:si + k, si:si + k]
    if k < m:
        out[so, :] = 0.0
        out[:, so] = 0.0
    return np.real(np.fft.ifft2(np.fft.ifftshift(out))) * (size * size) / (m * m)


def _whole_image_albedo(name: str, size: int, seed: int) -> np.ndarray:
    """A photo layer's albedo from whole images: periodic component, Fourier resize, pixel
    Gaussian high-pass and blur, fBm, percentile normalisation (the previous code)."""
    import skimage.data

    rec = _RECIPES[name]
    rng = np.random.default_rng(np.random.SeedSequence([seed, MATERIAL_LAYERS.index(name), 7]))
    photo = np.asarray(getattr(skimage.data, rec.photo)(), dtype=np.float64) / 255.0
    side = photo.shape[0]
    crop = round(min(side, side / rec.zoom))
    tile = periodic_component(photo[:crop, :crop])
    if rec.zoom < 1.0:
        reps = int(np.ceil(1.0 / rec.zoom))
        tile = np.tile(periodic_component(photo), (reps, reps))
    base = _fourier_resize(tile, size)
    base = base - ndimage.gaussian_filter(base, size / 8.0, mode="grid-wrap")
    if rec.blur > 0.0:
        base = ndimage.gaussian_filter(base, rec.blur, mode="grid-wrap")
    base /= max(float(base.std()), 1e-9)
    h = base
    if rec.noise > 0.0:
        n = periodic_fbm(size, (4, 4), rng, octaves=5, gain=0.55)
        h = h + rec.noise * n / max(float(n.std()), 1e-9)
    if rec.ridged > 0.0:
        r = periodic_fbm(size, (3, 3), rng, octaves=3, ridged=True)
        h = h - rec.ridged * np.clip(r, 0.0, 1.0) ** 4 / max(float(r.std()), 1e-9)
    lo, hi = np.percentile(h, [1.0, 99.0])
    h = np.clip(0.02 + 0.96 * (h - lo) / (hi - lo), 0.0, 1.0)
    dark, light = np.asarray(rec.dark, np.float64), np.asarray(rec.light, np.float64)
    return np.rint(dark + (light - dark) * h[..., None]).clip(0, 255).astype(np.uint8)


@pytest.mark.parametrize("size", [16, 64])
def test_photo_layers_are_the_whole_image_bytes(size: int, monkeypatch) -> None:
    # blocks of 5 rows (the last one short) for the single material; the layer set as well
    monkeypatch.setattr(photo_materials, "_BLOCK_PIXELS", size * 5)
    photo_materials._cached_layers.cache_clear()
    try:
        layers = photo_material_layers(size, seed=3)
        for k, name in enumerate(MATERIAL_LAYERS):
            expected = _whole_image_albedo(name, size, 3)
            assert np.array_equal(layers.albedo[k, ..., :3], expected), name
            assert np.array_equal(photo_material(name, size, seed=3), expected), name
    finally:
        photo_materials._cached_layers.cache_clear()


def test_photo_material_alone_equals_its_layer_at_the_default_size() -> None:
    layers = photo_material_layers(256, seed=1)
    for k in (MATERIAL_LAYERS.index("meadow"), MATERIAL_LAYERS.index("rock")):
        assert np.array_equal(photo_material(MATERIAL_LAYERS[k], 256, seed=1),
                              layers.albedo[k, ..., :3])


# --- exact percentiles from blocks -----------------------------------------------------------
@pytest.mark.parametrize("seed", range(6))
def test_block_percentiles_are_numpys(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5000))
    values = [rng.normal(size=n), rng.integers(-3, 4, n).astype(float),
              np.abs(rng.normal(size=n)) * 1e-9, np.r_[rng.normal(size=n), -0.0, 0.0, 0.0],
              np.full(n, 2.5)][seed % 5]
    q = [0.0, 1.0, 5.0, 50.0, 90.0, 95.0, 99.0, 100.0, float(rng.uniform(0, 100))]
    parts = np.split(values, np.sort(rng.integers(0, values.size, 4)))
    assert block_percentiles(lambda: iter(parts), q) == list(np.percentile(values, q))
    assert block_percentiles(lambda: iter([np.empty(0)]), [50.0]) is None


# --- the terrain material --------------------------------------------------------------------
def _terrain_case():
    rng = np.random.default_rng(5)
    hm = Heightmap(generate("fbm", 97, seed=3).heights[:70] * 3, (2.0, 1.5))
    masks = {
        "flow": rng.gamma(0.3, size=hm.shape).astype(np.float32),
        "deposition": np.where(rng.random(hm.shape) < 0.3, rng.random(hm.shape), 0.0),
        "wear": rng.random(hm.shape),
        "water": (rng.random(hm.shape) < 0.05).astype(np.float32),
    }
    rules = terrain_material.MaterialRules(water_level=float(np.quantile(hm.heights, 0.1)))
    return hm, masks, rules


def test_terrain_material_blocks_give_the_whole_map_bytes(monkeypatch) -> None:
    hm, masks, rules = _terrain_case()
    # one block: every filter runs on the whole map, as before the blocks
    monkeypatch.setattr(terrain_material, "_BLOCK_SAMPLES", 1 << 30)
    whole_w = terrain_material.material_weights(hm, masks=masks, rules=rules, seed=4)
    whole_img = terrain_material.material_texture(hm, masks=masks, rules=rules, seed=4, scale=3)
    plain = terrain_material.material_texture(hm, seed=4)
    for rows in (5, 17):  # blocks thinner than the 13-row halo, and thicker
        monkeypatch.setattr(terrain_material, "_BLOCK_SAMPLES", hm.cols * rows)
        w = terrain_material.material_weights(hm, masks=masks, rules=rules, seed=4)
        assert np.array_equal(w, whole_w)
        img = terrain_material.material_texture(hm, masks=masks, rules=rules, seed=4, scale=3)
        assert np.array_equal(img, whole_img)
        assert np.array_equal(terrain_material.material_texture(hm, weights=w, seed=4, scale=3),
                              whole_img)
        assert np.array_equal(terrain_material.material_texture(hm, seed=4), plain)
    assert len(np.unique(plain.reshape(-1, 3), axis=0)) > 100  # a textured image, not a fill


def _traced_peak(job):
    photo_materials._cached_layers.cache_clear()
    tracemalloc.start()
    try:
        result = job()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
        photo_materials._cached_layers.cache_clear()
    return peak, result


#: Bytes per pixel Pillow holds while encoding an RGB image (it stores RGB as 4 bytes); not
#: seen by tracemalloc, which traces Python's and numpy's allocations only.
PILLOW_BYTES = 4


def _check_estimate(command: str, small_peak: float, peak: float, shape: tuple[int, int],
                    small_shape: tuple[int, int], input_bytes: float = 0.0,
                    extra: float = 0.0) -> None:
    """The memory model's estimate covers the measured growth over a tiny run (what the
    estimate is of: the imports and fixed costs are in the tiny run) and is at most 2× it:
    an estimate, not a wild guard (it was 12× for the terrain material). The model is of the
    resident memory, which ``/usr/bin/time -v`` measured about 1.4× the traced bytes (freed
    blocks the allocator keeps, zlib's buffers while the PNG is written)."""
    from terrascape.memory import estimate_peak

    pixels = shape[0] * shape[1] - small_shape[0] * small_shape[1]
    measured = peak - small_peak + PILLOW_BYTES * pixels + input_bytes
    estimate = estimate_peak(command, *shape) - estimate_peak(command, *small_shape) + extra
    assert measured <= estimate <= 2.0 * measured, (
        f"{command}: estimate {estimate / 2**20:.1f} MiB, measured {measured / 2**20:.1f} MiB")


@pytest.mark.slow
def test_terrain_material_peak_is_a_few_times_the_image() -> None:
    hm = generate("fbm", 1025, seed=1)
    small_hm = generate("fbm", 65, seed=1)
    terrain_material.material_texture(small_hm, seed=1)  # compile the kernel outside the trace
    peak, img = _traced_peak(lambda: terrain_material.material_texture(hm, seed=1))
    # 3 MiB of RGB; the fixed part (the 256² photo layers, being made) is about 10 MiB, so the
    # bound is met with room only for a few blocks (it was 85×; 2049²: ≤ 4×, bench memory).
    assert peak <= 7.0 * img.nbytes, f"peak {peak / img.nbytes:.1f}× the image"
    small_peak, _ = _traced_peak(lambda: terrain_material.material_texture(small_hm, seed=1))
    # the command reads the float32 heightmap too (4 B a sample, made outside the trace here)
    _check_estimate("texture material", small_peak, peak, hm.shape, small_hm.shape,
                    input_bytes=hm.heights.nbytes - small_hm.heights.nbytes)


@pytest.mark.slow
def test_photo_material_peak_is_a_few_times_the_image() -> None:
    peak, img = _traced_peak(lambda: photo_material("scree", 1024, seed=1))
    # 3 MiB of RGB; the 512² source photo and its spectrum are a fixed ~10 MiB (68× before).
    assert peak <= 8.0 * img.nbytes, f"peak {peak / img.nbytes:.1f}× the image"
    small_peak, _ = _traced_peak(lambda: photo_material("scree", 16, seed=1))
    _check_estimate("texture photo", small_peak, peak, (1024, 1024), (16, 16),
                    extra=layer_spectrum_bytes(1024) - layer_spectrum_bytes(16))
