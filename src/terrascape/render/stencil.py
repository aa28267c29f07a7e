"""The stencil buffer, which moderngl does not expose, through PyOpenGL on moderngl's current
context: a framebuffer with a packed depth + stencil attachment, the z-fail counting state
of stencil shadow volumes, and the stencil test of the shading pass after it.

PyOpenGL calls go to whatever context is current, so every function here runs inside the
renderer's ``current(ctx)`` block. GL state that moderngl keeps a copy of (colour and depth
write masks, depth function, face culling, polygon offset) is set through moderngl so its
copy stays right; only the stencil state and depth clamping, which moderngl never touches,
go through PyOpenGL.

References
----------
Everitt, C. & Kilgard, M. J. (2002). Practical and robust stenciled shadow volumes for
hardware-accelerated rendering. NVIDIA technical report (arXiv:cs/0301002).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np

from terrascape.errors import GLUnavailableError


def _gl():
    """PyOpenGL's GL module, or GLUnavailableError when it is not installed."""
    try:
        from OpenGL import GL
    except ImportError as exc:  # the "render" extra installs it
        raise GLUnavailableError(
            "stencil shadow volumes need PyOpenGL (pip install 'terrascape[render]')") from exc
    # PyOpenGL checks glGetError after each call: an error an earlier (moderngl) call left
    # behind would be blamed on ours, so the queue is emptied first.
    while GL.glGetError() != GL.GL_NO_ERROR:
        pass
    return GL


def stencil_bits(fbo) -> int:
    """Stencil bits of moderngl framebuffer ``fbo`` (0: none, or PyOpenGL is missing)."""
    try:
        GL = _gl()
    except GLUnavailableError:
        return 0
    from OpenGL.error import GLError

    fbo.use()
    try:
        if fbo.glo == 0:  # the default framebuffer of a window
            return int(GL.glGetFramebufferAttachmentParameteriv(
                GL.GL_FRAMEBUFFER, GL.GL_STENCIL, GL.GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE))
        kind = GL.glGetFramebufferAttachmentParameteriv(
            GL.GL_FRAMEBUFFER, GL.GL_STENCIL_ATTACHMENT,
            GL.GL_FRAMEBUFFER_ATTACHMENT_OBJECT_TYPE)
        if int(kind) == GL.GL_NONE:
            return 0
        return int(GL.glGetFramebufferAttachmentParameteriv(
            GL.GL_FRAMEBUFFER, GL.GL_STENCIL_ATTACHMENT,
            GL.GL_FRAMEBUFFER_ATTACHMENT_STENCIL_SIZE))
    except GLError:  # no stencil attachment to ask about
        return 0


class StencilFramebuffer:
    """An off-screen target with an RGBA8 colour and a DEPTH24_STENCIL8 renderbuffer.

    ``fbo`` is a moderngl framebuffer (``ctx.detect_framebuffer`` of the PyOpenGL one), so
    the renderer draws into it like into any other; ``release()`` frees both. With
    ``color_texture`` (a moderngl texture of ``size``, still the caller's) the colour goes
    into that texture instead of a renderbuffer, to be sampled afterwards.

    Raises
    ------
    GLUnavailableError
        PyOpenGL is missing or the GL cannot make a complete depth + stencil framebuffer.
    """

    def __init__(self, ctx, size: tuple[int, int], *, color_texture=None) -> None:
        GL = _gl()
        self.ctx = ctx
        self.size = (int(size[0]), int(size[1]))
        w, h = self.size
        self._glo = 0
        self.color = None if color_texture is not None else ctx.renderbuffer((w, h), 4,
                                                                              samples=0)
        self._depth_stencil = int(GL.glGenRenderbuffers(1))
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, self._depth_stencil)
        GL.glRenderbufferStorage(GL.GL_RENDERBUFFER, GL.GL_DEPTH24_STENCIL8, w, h)
        GL.glBindRenderbuffer(GL.GL_RENDERBUFFER, 0)
        self._glo = int(GL.glGenFramebuffers(1))
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, self._glo)
        if color_texture is not None:
            GL.glFramebufferTexture2D(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0,
                                      GL.GL_TEXTURE_2D, color_texture.glo, 0)
        else:
            GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_COLOR_ATTACHMENT0,
                                         GL.GL_RENDERBUFFER, self.color.glo)
        GL.glFramebufferRenderbuffer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_STENCIL_ATTACHMENT,
                                     GL.GL_RENDERBUFFER, self._depth_stencil)
        status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
        if status != GL.GL_FRAMEBUFFER_COMPLETE:
            self.release()
            raise GLUnavailableError(
                f"this GL cannot make a depth + stencil framebuffer (status 0x{int(status):x})")
        self.fbo = ctx.detect_framebuffer(self._glo)

    def read_stencil(self) -> np.ndarray:
        """uint8 ``(h, w)`` stencil values, row 0 at the top."""
        return read_stencil(self.fbo)

    def read_depth(self) -> np.ndarray:
        """float32 ``(h, w)`` window depth in [0, 1], row 0 at the top."""
        GL = _gl()
        self.fbo.use()
        w, h = self.size
        GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
        raw = GL.glReadPixels(0, 0, w, h, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT)
        return np.frombuffer(raw, np.float32).reshape(h, w)[::-1].copy()

    def release(self) -> None:
        GL = _gl()
        if getattr(self, "fbo", None) is not None:
            self.fbo.release()
            self.fbo = None
        if self._glo:
            GL.glDeleteFramebuffers(1, [self._glo])
            self._glo = 0
        if self._depth_stencil:
            GL.glDeleteRenderbuffers(1, [self._depth_stencil])
            self._depth_stencil = 0
        if self.color is not None:
            self.color.release()
            self.color = None


def read_stencil(fbo) -> np.ndarray:
    """uint8 ``(h, w)`` stencil values of moderngl framebuffer ``fbo``, row 0 at the top."""
    GL = _gl()
    fbo.use()
    w, h = fbo.size
    GL.glPixelStorei(GL.GL_PACK_ALIGNMENT, 1)
    raw = GL.glReadPixels(0, 0, w, h, GL.GL_STENCIL_INDEX, GL.GL_UNSIGNED_BYTE)
    return np.frombuffer(raw, np.uint8).reshape(h, w)[::-1].copy()


def clear_stencil(fbo, value: int = 0) -> None:
    """Set every stencil value of ``fbo`` (moderngl's ``clear`` leaves the stencil alone)."""
    GL = _gl()
    fbo.use()
    GL.glStencilMask(0xFF)
    GL.glClearStencil(int(value))
    GL.glClear(GL.GL_STENCIL_BUFFER_BIT)


@contextlib.contextmanager
def zfail_counting(ctx, fbo, *, depth_offset: float = 2.0,
                   depth_clamp: bool = True) -> Iterator[None]:
    """GL state of the volume pass (Everitt & Kilgard's z-fail, two-sided in one draw).

    Colour and depth writes off, the depth test on (GL_LESS against the scene's depth), both
    faces drawn: a back face whose fragment is behind the scene's surface increments the
    count, a front face behind it decrements it (wrapping, so the order of faces does not
    matter); the sum is the number of volumes the surface point is in. Drawn with an
    infinite far plane (:attr:`terrascape.camera.Camera.infinite_far`) no part of a volume
    lies beyond the far plane; ``depth_clamp`` (GL_DEPTH_CLAMP) is the belt to those braces:
    with a finite far plane it keeps the parts beyond it at the far plane's depth instead of
    clipping them, where they still fail the depth test, as they must. ``depth_offset``
    (polygon offset units) pushes the near caps just behind the lit faces they lie on, so a
    caster's own sunlit surface is outside its volume.
    """
    import moderngl

    GL = _gl()
    fbo.use()
    fbo.color_mask = (False, False, False, False)
    fbo.depth_mask = False
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.disable(moderngl.CULL_FACE)
    ctx.depth_func = "<"
    ctx.polygon_offset = (0.0, float(depth_offset))
    fbo.use()  # moderngl applies the masks when the framebuffer is bound
    if depth_clamp:
        GL.glEnable(GL.GL_DEPTH_CLAMP)
    GL.glEnable(GL.GL_STENCIL_TEST)
    GL.glStencilMask(0xFF)
    GL.glStencilFunc(GL.GL_ALWAYS, 0, 0xFF)
    GL.glStencilOpSeparate(GL.GL_BACK, GL.GL_KEEP, GL.GL_INCR_WRAP, GL.GL_KEEP)
    GL.glStencilOpSeparate(GL.GL_FRONT, GL.GL_KEEP, GL.GL_DECR_WRAP, GL.GL_KEEP)
    try:
        yield
    finally:
        GL.glDisable(GL.GL_STENCIL_TEST)
        GL.glDisable(GL.GL_DEPTH_CLAMP)
        GL.glStencilOp(GL.GL_KEEP, GL.GL_KEEP, GL.GL_KEEP)
        ctx.polygon_offset = (0.0, 0.0)
        fbo.color_mask = (True, True, True, True)
        fbo.depth_mask = True
        fbo.use()


@contextlib.contextmanager
def stencil_test(nonzero: bool = True) -> Iterator[None]:
    """Draw only where the stencil is non-zero (``nonzero``) or zero; the stencil is kept."""
    GL = _gl()
    GL.glEnable(GL.GL_STENCIL_TEST)
    GL.glStencilMask(0x00)
    GL.glStencilFunc(GL.GL_NOTEQUAL if nonzero else GL.GL_EQUAL, 0, 0xFF)
    GL.glStencilOp(GL.GL_KEEP, GL.GL_KEEP, GL.GL_KEEP)
    try:
        yield
    finally:
        GL.glDisable(GL.GL_STENCIL_TEST)
        GL.glStencilMask(0xFF)


@contextlib.contextmanager
def stencil_replace(value: int) -> Iterator[None]:
    """Write ``value`` into the stencil wherever a fragment passes the depth test."""
    GL = _gl()
    GL.glEnable(GL.GL_STENCIL_TEST)
    GL.glStencilMask(0xFF)
    GL.glStencilFunc(GL.GL_ALWAYS, int(value), 0xFF)
    GL.glStencilOp(GL.GL_KEEP, GL.GL_KEEP, GL.GL_REPLACE)
    try:
        yield
    finally:
        GL.glStencilOp(GL.GL_KEEP, GL.GL_KEEP, GL.GL_KEEP)
        GL.glDisable(GL.GL_STENCIL_TEST)


__all__ = [
    "StencilFramebuffer",
    "clear_stencil",
    "read_stencil",
    "stencil_bits",
    "stencil_replace",
    "stencil_test",
    "zfail_counting",
]
