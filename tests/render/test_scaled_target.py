"""The scaled target: a small frame enlarged onto the output with the Catmull-Rom filter."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from terrascape.errors import InvalidParameterError
from terrascape.render.scaled_target import ScaledTarget, scaled_size

OUT = (160, 96)


def _catmull_rom_1d(n_src: int, n_dst: int) -> np.ndarray:
    """``(n_dst, n_src)`` matrix of the Catmull-Rom enlargement, edge texels repeated."""
    m = np.zeros((n_dst, n_src))
    for d in range(n_dst):
        pos = (d + 0.5) * n_src / n_dst - 0.5
        i = int(np.floor(pos))
        f = pos - i
        w = [f * (-0.5 + f * (1.0 - 0.5 * f)), 1.0 + f * f * (-2.5 + 1.5 * f),
             f * (0.5 + f * (2.0 - 1.5 * f)), f * f * (-0.5 + 0.5 * f)]
        for k, wk in zip(range(i - 1, i + 3), w, strict=True):
            m[d, min(max(k, 0), n_src - 1)] += wk
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
def test_enlargement_is_the_catmull_rom_filter(gl_ctx):
    w, h = scaled_size(OUT, 0.6)
    rng = np.random.default_rng(4)
    smooth = gaussian_filter(rng.uniform(0, 255, (h, w, 3)), (1.5, 1.5, 0))
    smooth = 40 + (smooth - smooth.min()) / np.ptp(smooth) * 170
    small = np.rint(smooth).astype(np.uint8)
    got = _enlarged(gl_ctx, small, 0.6)
    rows, cols = _catmull_rom_1d(h, OUT[1]), _catmull_rom_1d(w, OUT[0])
    want = np.einsum("ri,ijc,dj->rdc", rows, small.astype(float), cols)
    err = np.abs(got - want)
    # the shader drops the 4×4 footprint's four corner taps (weights below 1 %)
    assert err.max() <= 3.0 and err.mean() <= 0.6, (err.max(), err.mean())


@pytest.mark.gl
def test_enlargement_keeps_edges_sharper_than_bilinear(gl_ctx):
    w, h = scaled_size(OUT, 0.25)  # 4× enlarged: the filters' ramps differ by pixels
    small = np.zeros((h, w, 3), np.uint8)
    small[:, w // 2:] = 200
    got = _enlarged(gl_ctx, small, 0.25)[OUT[1] // 2, :, 0]
    # the step lies in the middle of the output, as in the input
    assert got[: OUT[0] // 2 - 3].max() <= 12 and got[OUT[0] // 2 + 3:].min() >= 188
    ramp = np.nonzero((got > 20) & (got < 180))[0]  # 10-90 % of the step
    bilinear = np.interp(((np.arange(OUT[0]) + 0.5) * w / OUT[0] - 0.5), np.arange(w),
                         small[0, :, 0].astype(float))
    ramp_bilinear = np.nonzero((bilinear > 20) & (bilinear < 180))[0]
    assert 0 < len(ramp) < len(ramp_bilinear)
    assert np.diff(got).max() > np.diff(bilinear).max()
