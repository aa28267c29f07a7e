"""Headless context creation and description."""

from __future__ import annotations

import pytest

from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.render.context import create_headless_context, describe_context

pytestmark = pytest.mark.gl


def test_describe_context_reports_version_and_limits(gl_ctx):
    info = describe_context(gl_ctx)
    assert info["version_code"] >= 330
    assert isinstance(info["renderer"], str) and info["renderer"]
    assert info["max_texture_size"] >= 1024
    assert len(info["max_viewport_dims"]) == 2 and min(info["max_viewport_dims"]) >= 1024


def test_bad_backend_gives_clear_error():
    with pytest.raises(GLUnavailableError, match=r"apt-get install libegl1 libgl1-mesa-dri"):
        create_headless_context(backend="no-such-backend")


def test_too_high_version_is_refused(gl_ctx):
    with pytest.raises(GLUnavailableError, match=r"OpenGL >= 9\.9"):
        create_headless_context(require=(9, 9))


@pytest.mark.parametrize("require", [(2, 1), (3, 2), "x", (3,)])
def test_bad_require(require):
    with pytest.raises(InvalidParameterError):
        create_headless_context(require=require)


def test_temporary_context_restores_the_current_one(gl_ctx):
    from terrascape.render.context import current, headless_context

    with current(gl_ctx):
        with headless_context() as tmp:
            assert tmp is not gl_ctx
        # without the restore, no context is current here and GL calls fail
        tex = gl_ctx.texture((2, 2), 4)
        fbo = gl_ctx.framebuffer([tex])
        fbo.use()
        fbo.clear(1.0, 0.0, 0.0, 1.0)
        assert fbo.read(components=4)[:4] == b"\xff\x00\x00\xff"
        fbo.release()
        tex.release()
