"""Each terrain program is compiled for its frame's lighting mode and cascade use (a
software rasteriser pays every branch on every pixel), with daylight's haze per vertex on
level-of-detail meshes: the frames are those of the one program with every branch and the
haze per pixel, within a level, with no band or line."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrascape.generate.registry import generate
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.render.techniques import get_technique

pytestmark = pytest.mark.gl

EVERY_BRANCH = {"TERRAIN_LIGHTING": "u_lighting", "TERRAIN_CASCADES": 1,
                "TERRAIN_VERTEX_HAZE": 0}


@pytest.fixture(scope="module")
def renderer(gl_ctx):
    hm = generate("diamond-square", 65, seed=3, spacing=4.0)
    r = OffscreenRenderer(gl_ctx, hm, size=(128, 72))
    yield r
    r.release()


@pytest.mark.parametrize("technique, lighting", [
    ("plain", "daylight"), ("plain", "vertex"), ("plain", "lightmap"), ("material", "daylight"),
    ("bump", "daylight"),
])
def test_specialised_programs_draw_the_same_frames(renderer, technique, lighting):
    tech = get_technique(technique)
    general = replace(tech, defines={**(tech.defines or {}), **EVERY_BRANCH})
    params = {"sun": (135.0, 30.0), "lighting": lighting}
    cam = renderer.default_camera()
    fast = renderer.render(cam, tech, params)[..., :3].astype(float)
    slow = renderer.render(cam, general, params)[..., :3].astype(float)
    assert renderer.terrain.last_technique == technique
    diff = np.abs(fast - slow)
    assert diff.mean() < 1.0
    # no band or line: no row or column differs on average by a level
    assert diff.mean(axis=(1, 2)).max() < 1.0 and diff.mean(axis=(0, 2)).max() < 1.0
    assert fast.std() > 5  # a picture


def test_haze_per_vertex_only_where_vertices_are_fewer_than_pixels(gl_ctx):
    # A grid with more vertices than the frame has pixels is hazed per pixel; a
    # level-of-detail triangulation (here the grid's own triangles, set as one) per vertex:
    # the same frame within a level.
    r = OffscreenRenderer(gl_ctx, generate("diamond-square", 129, seed=3, spacing=16.0),
                          size=(128, 72))
    try:
        terrain = r.terrain
        cam = r.default_camera()
        params = {"sun": (135.0, 30.0)}
        per_pixel = r.render(cam, "plain", params)[..., :3].astype(float)
        assert not terrain._haze_per_vertex()  # 129² vertices, 128×72 pixels
        terrain.set_indices(terrain.mesh.triangles)
        per_vertex = r.render(cam, "plain", params)[..., :3].astype(float)
        assert terrain._haze_per_vertex()
    finally:
        r.release()
    diff = np.abs(per_pixel - per_vertex)
    assert diff.mean() < 1.0
    assert diff.mean(axis=(1, 2)).max() < 1.0 and diff.mean(axis=(0, 2)).max() < 1.0
