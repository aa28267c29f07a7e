"""The scaled target: a small frame enlarged onto the output with the linear filter."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from terrascape.errors import InvalidParameterError
from terrascape.render.scaled_target import ScaledTarget, scaled_size

OUT = (160, 96)


def _linear_1d(n_src: int, n_dst: int) -> np.ndarray:
    """``(n_dst, n_src)`` matrix of the linear enlargement, edge texels repeated."""
    m = np.zeros((n_dst, n_src))
    for d in range(n_dst):
        pos = min(max((d + 0.5) * n_src / n_dst - 0.5, 0.0), n_src - 1.0)
        i = min(int(np.floor(pos)), n_src - 2)
        f = pos - i
        m[d, i] += 1.0 - f
        m[d, i + 1] += f
    return m


def _enlarged(gl_ctx, image: np.ndarray, scale: float) -> np.ndarray:
    """``image`` (rows top-down, uint8 RGB of the small size) through the scaled target."""
    st = ScaledTarget(gl_ctx)
    dst = gl_ctx.simple_framebuffer(OUT)
    try:
        fbo = st.target(OUT, scale)
        h, w = image.shape[:2]
        assert fbo.size == (w, h)
        rgba = np.concatenate([image, np.full((h, w, 1), 255, np.uint8)], axis=-1)
        fbo.color_attachments[0].write(np.ascontiguousarray(rgba[::-1]).tobytes())
        st.present(dst)
        raw = dst.read(components=3, alignment=1)
        return np.frombuffer(raw, np.uint8).reshape(OUT[1], OUT[0], 3)[::-1].astype(float)
    finally:
        dst.release()
        st.release()


def test_scaled_size_rounds_and_refuses_bad_scales():
    assert scaled_size((1280, 720), 0.6) == (768, 432)
    assert scaled_size((3, 3), 0.01) == (1, 1)
    for bad in (0.0, 1.5, -0.2):
        with pytest.raises(InvalidParameterError, match="render scale"):
            scaled_size((100, 100), bad)


@pytest.mark.gl
def test_enlargement_is_the_linear_filter_in_place(gl_ctx):
    w, h = scaled_size(OUT, 0.6)
    rng = np.random.default_rng(4)
    noise = gaussian_filter(rng.uniform(0, 255, (h, w, 3)), (1.0, 1.0, 0))
    small = np.rint(20 + (noise - noise.min()) / np.ptp(noise) * 210).astype(np.uint8)
    got = _enlarged(gl_ctx, small, 0.6)
    rows, cols = _linear_1d(h, OUT[1]), _linear_1d(w, OUT[0])
    want = np.einsum("ri,ijc,dj->rdc", rows, small.astype(float), cols)
    err = np.abs(got - want)
    # texture filtering weights have 8 bits on llvmpipe: within one or two levels
    assert err.max() <= 2.0 and err.mean() <= 0.5, (err.max(), err.mean())
    # a shift by one output pixel or a flip would be far off
    assert np.abs(got[:, 1:] - want[:, :-1]).mean() > 2 * err.mean() + 1
    assert np.abs(got[::-1] - want).mean() > 10


@pytest.mark.gl
def test_a_step_stays_where_it_was(gl_ctx):
    w, h = scaled_size(OUT, 0.5)
    small = np.zeros((h, w, 3), np.uint8)
    small[:, w // 2:] = 200
    got = _enlarged(gl_ctx, small, 0.5)[OUT[1] // 2, :, 0]
    assert got[: OUT[0] // 2 - 2].max() == 0 and got[OUT[0] // 2 + 2:].min() == 200
    assert abs(got[OUT[0] // 2 - 1] + got[OUT[0] // 2] - 200) <= 2  # symmetric about it


@pytest.mark.gl
def test_geometry_buffers_of_two_sizes_are_kept_and_the_oldest_goes(gl_ctx):
    """The viewer alternates full-size and smaller frames: both geometry buffers stay,
    and a third size releases the one used longest ago."""
    from terrascape.render.deferred import KEPT_GBUFFERS, DeferredShading

    assert KEPT_GBUFFERS == 2
    shading = DeferredShading(gl_ctx)
    try:
        full = shading._gbuffer_for((160, 96))
        small = shading._gbuffer_for((96, 58))
        assert shading._gbuffer_for((160, 96)) is full  # no reallocation
        assert shading._gbuffer_for((96, 58)) is small
        shading._gbuffer_for((160, 96))
        third = shading._gbuffer_for((64, 40))
        assert set(shading._gbuffers) == {((160, 96), True), ((64, 40), True)}
        assert shading._gbuffer_for((64, 40)) is third
        assert shading._gbuffer_for((96, 58)) is not small  # made again
    finally:
        shading.release()
    assert shading._gbuffers == {}
