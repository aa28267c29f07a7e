"""The terrain's haze from the per-frame horizon sky table equals the sky model per pixel."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.generate.registry import generate
from terrascape.render.offscreen import OffscreenRenderer
from terrascape.render.techniques import get_technique

pytestmark = pytest.mark.gl


@pytest.mark.parametrize("sun", [(135.0, 35.0), (250.0, 6.0)])
def test_haze_table_matches_the_sky_per_pixel(gl_ctx, sun):
    hm = generate("diamond-square", 129, seed=5, spacing=4.0)
    w, d = hm.extent
    # low over the terrain looking across it toward the horizon: far pixels are mostly haze
    cam = Camera.look_at((0.05 * w, hm.max * 0.9, 0.05 * d), (w, hm.min, d), fov_y=60.0,
                         near=1.0, far=6.0 * w, aspect=1.6)
    r = OffscreenRenderer(gl_ctx, hm, size=(320, 200))
    try:
        params = {"sun": sun, "haze": 4.0 / w}  # thick haze: the horizon colour dominates
        plain = get_technique("plain")
        exact = replace(plain, name="plain_exact_haze",
                        defines={**plain.defines, "EXACT_HAZE": 1})
        a = r.render(cam, technique="plain", params=params)[..., :3].astype(int)
        b = r.render(cam, technique=exact, params=params)[..., :3].astype(int)
        clear = r.render(cam, technique="plain", params={**params, "haze": 0.0})
    finally:
        r.release()
    # the haze is what the picture shows (not a test of nothing) ...
    assert np.abs(a - clear[..., :3].astype(int)).mean() > 10
    # ... and the table gives the per-pixel sky's colour within a level or two
    diff = np.abs(a - b)
    assert diff.max() <= 3
    assert diff.mean() < 0.3
