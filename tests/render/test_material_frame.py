"""The default look (``material``, deferred on a software rasteriser) draws the frames it
drew before its geometry buffer and texture lookups were made cheaper.

``data/material_*.png`` were rendered by the renderer before those changes (float32
geometry buffer with every attachment cleared and the tangents stored, one ``textureGrad``
per hex-tile lookup, RGBA detail normals) on llvmpipe: a landscape view, a far overview with
the skirts, and the landscape with a sea. Regenerate them only for an intended change of the
picture (``python tests/render/test_material_frame.py``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).with_name("data")
SIZE = (320, 180)
FRAMES = ("landscape", "overview", "sea")
# float16 normals, the rebuilt tangents and one mip level per pixel move a pixel by a level
# at most; a lost attachment, texture or lookup moves whole regions by tens of levels
MAX_LEVELS = 2
MEAN_LEVELS = 0.05


def _terrain():
    from terrascape.generate.registry import VIEW_SPACING, generate

    return generate("diamond-square", 129, seed=1, spacing=VIEW_SPACING)


def _render(r, frame: str) -> np.ndarray:
    if frame == "overview":
        return r.render(r.default_camera(elevation=35.0), "material")
    params = {"sea_level": 0.3 * r.terrain.heightmap.max} if frame == "sea" else None
    return r.render(r.default_camera(), "material", params)


@pytest.fixture(scope="module")
def renderer(gl_ctx):
    from terrascape.render.offscreen import OffscreenRenderer

    r = OffscreenRenderer(gl_ctx, _terrain(), size=SIZE)
    yield r
    r.release()


def _software(ctx) -> bool:
    from terrascape.render.context import describe_context

    return "llvmpipe" in describe_context(ctx)["renderer"].lower()


@pytest.mark.gl
@pytest.mark.parametrize("frame", FRAMES)
def test_material_frame_is_the_one_drawn_before(gl_ctx, renderer, frame):
    from PIL import Image

    if not _software(gl_ctx):
        pytest.skip("the reference frames were drawn by llvmpipe")
    img = _render(renderer, frame)[..., :3]
    assert renderer.terrain.last_stats.get("deferred") == 1
    want = np.asarray(Image.open(DATA / f"material_{frame}.png"))
    diff = np.abs(img.astype(int) - want.astype(int)).max(axis=-1)
    assert diff.max() <= MAX_LEVELS, f"{(diff > MAX_LEVELS).sum()} pixels differ"
    assert diff.mean() < MEAN_LEVELS


@pytest.mark.gl
def test_uncleared_attachments_leave_nothing_of_the_previous_frame(gl_ctx):
    # Only the world position's w and the depth are cleared: the normal attachment keeps
    # the previous frame where this one draws no terrain. A frame after another must be the
    # frame a fresh geometry buffer draws, bit for bit.
    from terrascape.render.offscreen import OffscreenRenderer

    hm = _terrain()
    fresh = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    reused = OffscreenRenderer(gl_ctx, hm, size=SIZE)
    try:
        want = _render(fresh, "landscape")
        _render(reused, "overview")  # terrain where the landscape has sky, and vice versa
        np.testing.assert_array_equal(_render(reused, "landscape"), want)
    finally:
        fresh.release()
        reused.release()


@pytest.mark.gl
def test_float16_attributes_draw_the_float32_frame(gl_ctx, monkeypatch):
    import terrascape.render.deferred as deferred
    from terrascape.render.offscreen import OffscreenRenderer

    r = OffscreenRenderer(gl_ctx, _terrain(), size=SIZE)
    try:
        half = _render(r, "landscape")
        monkeypatch.setattr(deferred, "GBUFFER_DTYPES", ("f4", "f4", "f4"))
        r.terrain._deferred.release()  # the next frame allocates float32 attachments
        full = _render(r, "landscape")
    finally:
        r.release()
    diff = np.abs(half.astype(int) - full.astype(int)).max(axis=-1)
    assert diff.max() <= 1
    assert (diff > 0).mean() < 0.01


if __name__ == "__main__":  # regenerate the reference frames (an intended change of a picture)
    from PIL import Image

    from terrascape.render.context import create_headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    r = OffscreenRenderer(create_headless_context(), _terrain(), size=SIZE)
    for name in FRAMES:
        Image.fromarray(_render(r, name)[..., :3]).save(DATA / f"material_{name}.png",
                                                        optimize=True)
    sys.exit(0)
