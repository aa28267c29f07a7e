"""Shadows of a moving sun: coarse at once, the exact map from the worker once still."""

from __future__ import annotations

import time

import numpy as np
import pytest

from terrascape.heightmap import Heightmap
from terrascape.lighting.shadows import soft_shadow
from terrascape.render.sun_shadows import MovingSunShadows, coarse_soft_shadow


def _ridge(n=129):
    y, x = np.mgrid[0:n, 0:n] / (n - 1)
    h = 30.0 * np.exp(-((x - 0.5) / 0.08) ** 2) + 3.0 * np.sin(7 * y)
    return Heightmap(h.astype(np.float32), (1.0, 1.0))


def test_coarse_map_is_the_sweep_of_the_subsampled_terrain_and_agrees_with_the_exact():
    hm = _ridge()
    coarse = coarse_soft_shadow(hm, 90.0, 15.0, max_side=33, samples=2)
    assert coarse.shape == (33, 33)
    exact = soft_shadow(hm, 90.0, 15.0, sun_radius_deg=0.5, samples=6)[::4, ::4]
    # the shadow west of the ridge is where the exact map has it (away from its edges)
    assert np.mean(np.abs(coarse - exact) < 0.5) > 0.9
    assert coarse[:, 2:12].mean() < 0.2 and coarse[:, 20:].mean() > 0.9


def test_moving_sun_gets_coarse_maps_then_the_exact_one_without_waiting():
    hm = _ridge()
    m = MovingSunShadows(hm, coarse_side=33)
    try:
        first_key, first = m.visibility(79.0, 20.0)  # the first map is exact, at once
        assert first_key[0] == "exact"
        assert np.array_equal(first, soft_shadow(hm, 79.0, 20.0, sun_radius_deg=0.5, samples=6))
        assert m.wait_ready(120.0)
        keys = []
        for az in (80.0, 81.0, 82.0):  # moving: a coarse map per position, never blocking
            key, vis = m.visibility(az, 20.0)
            assert key[0] == "coarse" and vis.shape == (33, 33)
            keys.append(key)
        assert len(set(keys)) == 3
        deadline = time.monotonic() + 60
        while True:  # still: the exact map arrives from the worker
            key, vis = m.visibility(82.0, 20.0)
            if key[0] == "exact":
                break
            assert time.monotonic() < deadline
            time.sleep(0.05)
        assert np.array_equal(vis, soft_shadow(hm, 82.0, 20.0, sun_radius_deg=0.5, samples=6))
    finally:
        m.close()


def test_without_a_worker_the_exact_map_is_computed_when_the_sun_stops():
    hm = _ridge(65)
    m = MovingSunShadows(hm, coarse_side=17, background=False)
    assert m.visibility(99.0, 30.0)[0][0] == "exact"  # the first frame
    assert m.visibility(100.0, 30.0)[0][0] == "coarse"
    key, vis = m.visibility(100.0, 30.0)
    assert key[0] == "exact"
    assert np.array_equal(vis, soft_shadow(hm, 100.0, 30.0, sun_radius_deg=0.5, samples=6))


@pytest.mark.gl
def test_a_new_sun_rewrites_the_visibility_texture_in_place(gl_ctx):
    """Each sun position writes its visibility map into the texture the renderer already
    has (no new texture per frame); the frame is the one a fresh renderer draws."""
    from terrascape.camera import Camera
    from terrascape.render.offscreen import OffscreenRenderer

    hm = _ridge(65)
    cam = Camera.look_at((32, 30, 90), (32, 0, 32), aspect=4 / 3, near=1.0, far=400.0)
    moving = OffscreenRenderer(gl_ctx, hm, size=(96, 72))
    try:
        moving.render(cam, "plain", {"sun": (90.0, 20.0), "lighting": "daylight"})
        tex = moving.terrain._env["u_sun_sky"][0]
        glo = tex.glo
        frame = moving.render(cam, "plain", {"sun": (250.0, 15.0), "lighting": "daylight"})
        assert moving.terrain._env["u_sun_sky"][0] is tex and tex.glo == glo
        fresh = OffscreenRenderer(gl_ctx, hm, size=(96, 72))
        try:
            ref = fresh.render(cam, "plain", {"sun": (250.0, 15.0), "lighting": "daylight"})
        finally:
            fresh.release()
        np.testing.assert_array_equal(frame, ref)
        # and the shadows really moved: the first sun's frame is another picture
        first = moving.render(cam, "plain", {"sun": (90.0, 20.0), "lighting": "daylight"})
        assert np.abs(first.astype(int) - frame.astype(int)).max() > 30
    finally:
        moving.release()
