"""An off-screen target at a fraction of the output's size, enlarged onto the output.

A software rasteriser's frame time is mostly per pixel: a frame drawn at 70 % of the
window's width and height shades half the pixels. :class:`ScaledTarget` holds that smaller
colour + depth target and draws it onto the real framebuffer with the linear filter
(``viewer/upscale.glsl``: one read per output pixel, the cheapest enlargement on a software
rasteriser). The viewer uses it to hold its frame rate while the camera moves (dynamic
resolution) and draws full size frames when it stops.
"""

from __future__ import annotations

from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.render.shaders import load_program


def scaled_size(size: tuple[int, int], scale: float) -> tuple[int, int]:
    """``size`` times ``scale`` in whole pixels, at least 1×1."""
    if not 0.0 < scale <= 1.0:
        raise InvalidParameterError(f"render scale must be in (0, 1], got {scale!r}")
    w, h = size
    return max(1, round(w * scale)), max(1, round(h * scale))


class ScaledTarget:
    """A colour + depth framebuffer of a context, reallocated when its size changes."""

    def __init__(self, ctx) -> None:
        self.ctx = ctx
        self._fbo = None
        self._colour = None
        self._depth = None
        self._stencil_target = None  # StencilFramebuffer holding the depth + stencil
        self._key: tuple | None = None
        self._vao = None

    @property
    def size(self) -> tuple[int, int] | None:
        return None if self._fbo is None else tuple(self._fbo.size)

    def target(self, size: tuple[int, int], scale: float, *, stencil: bool = False):
        """The framebuffer to draw a frame of output ``size`` into at ``scale``; with
        ``stencil`` it has a stencil buffer too, as the output has (stencil shadow volumes
        draw the same on both), when this GL can make one."""
        import moderngl

        want = scaled_size(size, scale)
        if self._fbo is None or self._key != (want, stencil):
            self._release_target()
            self._key = (want, stencil)
            self._colour = self.ctx.texture(want, 4)
            self._colour.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._colour.repeat_x = self._colour.repeat_y = False
            if stencil:
                from terrascape.render.stencil import StencilFramebuffer

                try:
                    self._stencil_target = StencilFramebuffer(self.ctx, want,
                                                              color_texture=self._colour)
                    self._fbo = self._stencil_target.fbo
                except GLUnavailableError:  # drawn without; the renderer says what falls back
                    self._stencil_target = None
            if self._fbo is None:
                self._depth = self.ctx.depth_renderbuffer(want)
                self._fbo = self.ctx.framebuffer(color_attachments=[self._colour],
                                                 depth_attachment=self._depth)
        return self._fbo

    def present(self, dst) -> None:
        """Draw the last frame drawn into :meth:`target` onto ``dst``, filling it."""
        import moderngl

        if self._fbo is None:
            raise InvalidParameterError("nothing drawn into the scaled target yet")
        program = load_program(self.ctx, "viewer/upscale")
        if self._vao is None:
            self._vao = self.ctx.vertex_array(program, [])
        program["u_frame"].value = 0
        dst.use()
        self.ctx.viewport = (0, 0, *dst.size)
        self._colour.use(location=0)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND | moderngl.CULL_FACE)
        self._vao.render(moderngl.TRIANGLES, vertices=3)

    def _release_target(self) -> None:
        if self._stencil_target is not None:
            self._stencil_target.release()  # its framebuffer is self._fbo
            self._fbo = None
        for obj in (self._fbo, self._colour, self._depth):
            if obj is not None:
                obj.release()
        self._fbo = self._colour = self._depth = self._stencil_target = None
        self._key = None

    def release(self) -> None:
        self._release_target()
        if self._vao is not None:
            self._vao.release()
            self._vao = None


__all__ = ["ScaledTarget", "scaled_size"]
