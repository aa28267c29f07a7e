"""Close up, the material technique lights a coarse grid with per-pixel normals (a cubic
B-spline over the vertex normals): no facets along the triangles' edges."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.heightmap import Heightmap
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.render.techniques import TextureData

pytestmark = pytest.mark.gl

LUMA = np.array([0.2126, 0.7152, 0.0722])


def _kinks(img: np.ndarray) -> np.ndarray:
    """|second difference| of the luminance along rows and columns (creases in the shading)."""
    lum = img[20:100, 30:130, :3].astype(float) @ LUMA
    return np.maximum(np.abs(np.diff(lum, 2, axis=1))[1:-1],
                      np.abs(np.diff(lum, 2, axis=0))[:, 1:-1])


def test_material_close_up_has_no_facets(gl_ctx):
    # rough relief on a 4 m grid seen from 50 m above: every cell spans about 10 pixels
    h = np.random.default_rng(3).normal(20.0, 2.5, (17, 17)).astype(np.float32)
    r = OffscreenRenderer(gl_ctx, Heightmap(h, (4.0, 4.0)), size=(160, 120))
    try:
        cam = Camera.look_at((32.0, 70.0, 20.0), (32.0, 20.0, 32.0), fov_y=40.0,
                             aspect=160 / 120)
        common = {"sun": (250.0, 25.0), "shadows": False, "haze": 0.0}
        # one flat grey everywhere: only the lighting varies
        grey = TextureData(np.full((7, 8, 8, 4), 150, np.uint8), kind="array")
        flat = np.zeros((7, 8, 8, 3), np.uint8)
        flat[...] = (128, 128, 255)
        smooth = r.render(cam, "material", {**common, "detail_strength": 0.0, "textures": {
            "u_layers": grey, "u_normals": TextureData(flat, kind="array")}})
        # the same light on normals interpolated over each triangle (plain texturing)
        faceted = r.render(cam, "plain", {**common, "textures": {
            "u_color_tex": np.full((8, 8, 3), 150, np.uint8)}})
    finally:
        r.release()
    lum_s = smooth[20:100, 30:130, :3].astype(float) @ LUMA
    lum_f = faceted[20:100, 30:130, :3].astype(float) @ LUMA
    # the same relief and light: the same brightness and contrast overall
    assert abs(lum_s.mean() - lum_f.mean()) < 8.0
    assert lum_s.std() > 0.6 * lum_f.std()
    # but no creases: the sharpest kinks a third of the faceted ones
    assert np.quantile(_kinks(smooth), 0.99) < 0.4 * np.quantile(_kinks(faceted), 0.99)
