"""The shaders' sRGB transfer curves (polynomials, common/atmosphere.glsl) against the
standard's curves evaluated on the CPU."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.lighting.daylight import linear_to_srgb, srgb_to_linear
from terrascape.render.shaders import load_program, set_uniforms

pytestmark = pytest.mark.gl

WIDTH = 4096


@pytest.fixture(scope="module")
def curves(gl_ctx):
    prog = load_program(gl_ctx, "debug/srgb_curves")
    tex = gl_ctx.texture((WIDTH, 1), 4, dtype="f4")
    fbo = gl_ctx.framebuffer(color_attachments=[tex])
    vao = gl_ctx.vertex_array(prog, [])
    try:
        fbo.use()
        set_uniforms(prog, u_width=float(WIDTH))
        vao.render(vertices=3)
        out = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(WIDTH, 4)
    finally:
        vao.release()
        fbo.release()
        tex.release()
    return out.astype(np.float64)


def test_ramp_is_every_input(curves):
    assert np.allclose(curves[:, 2], np.arange(WIDTH) / (WIDTH - 1.0), rtol=0, atol=1e-7)


def test_encoding_is_the_standard_curve_below_an_8_bit_step(curves):
    x = curves[:, 2]
    err = np.abs(curves[:, 0] - linear_to_srgb(x))
    assert err.max() < 0.03 / 255, err.max() * 255
    # the linear toe is exact, and the curve ends at 1
    toe = x <= 0.0031308
    assert np.allclose(curves[toe, 0], 12.92 * x[toe], rtol=1e-6, atol=1e-7)
    assert abs(curves[-1, 0] - 1.0) < 1e-4


def test_decoding_is_the_standard_curve_below_an_8_bit_step(curves):
    x = curves[:, 2]
    # as a displayed value: decoded by the shader, encoded back by the standard
    assert np.abs(linear_to_srgb(np.clip(curves[:, 1], 0, 1)) - x).max() < 0.04 / 255
    # the linear toe is exact, and the curve meets it and ends at 1
    toe = x <= 0.04045
    assert np.allclose(curves[toe, 1], x[toe] / 12.92, rtol=1e-6, atol=1e-9)
    assert np.abs(curves[:, 1] - srgb_to_linear(x)).max() < 1e-3
    assert abs(curves[-1, 1] - 1.0) < 5e-4
    # every 8-bit albedo comes back to itself
    levels = np.arange(256) * (WIDTH - 1) // 255
    ok = np.rint(linear_to_srgb(curves[levels, 1]) * 255) == np.rint(x[levels] * 255)
    assert ok.all()
