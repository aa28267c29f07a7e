"""Headless OpenGL context creation (EGL standalone) and a description of its capabilities.

The renderer needs OpenGL 3.3 core (the thesis's program builds on programmable vertex/fragment
shaders). On a machine without a GPU, Mesa's llvmpipe through EGL provides it; failures are
turned into :class:`~terrascape.errors.GLUnavailableError` with an actionable message instead
of the raw glcontext exception.

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.6.
"""

from __future__ import annotations

import contextlib
import functools
import weakref
from collections.abc import Iterator
from typing import Any

from terrascape.errors import GLUnavailableError, InvalidParameterError

INSTALL_HINT = (
    "install the headless GL drivers (Debian/Ubuntu: `apt-get install libegl1 libgl1-mesa-dri`)"
)


def _parse_require(require: Any) -> tuple[int, int]:
    try:
        major, minor = (int(v) for v in require)
    except (TypeError, ValueError):
        raise InvalidParameterError(
            f"require must be a (major, minor) GL version, got {require!r}"
        ) from None
    if major < 3 or (major == 3 and minor < 3):
        raise InvalidParameterError(
            f"require must be at least (3, 3) (the renderer's GLSL is 330 core), got {require!r}"
        )
    return major, minor


def create_headless_context(*, require=(3, 3), backend: str = "egl"):
    """Create a standalone (window-less) moderngl context.

    Parameters
    ----------
    require
        Minimum ``(major, minor)`` OpenGL version; at least ``(3, 3)``.
    backend
        glcontext backend; ``"egl"`` (default) works without a display server. Any other
        name is passed through, which lets tests force a failing backend.

    Returns
    -------
    moderngl.Context

    Raises
    ------
    GLUnavailableError
        When moderngl is not installed, the context cannot be created, or its version is
        below ``require``; the message says how to install the drivers.
    """
    major, minor = _parse_require(require)
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - moderngl is an install extra
        raise GLUnavailableError(
            f"moderngl is not installed ({exc}); `pip install terrascape[render]`"
        ) from None
    wanted = major * 100 + minor * 10
    # Remember the current EGL context: a refused context must not leave the caller's
    # context switched off.
    lib = _egl()
    saved = _egl_saved(lib) if lib is not None else None
    try:
        ctx = moderngl.create_standalone_context(require=wanted, backend=backend)
    except Exception as exc:  # glcontext raises plain Exception / ValueError / ImportError
        raise GLUnavailableError(
            f"could not create a headless OpenGL >= {major}.{minor} context with backend "
            f"{backend!r}: {exc}; {INSTALL_HINT}"
        ) from None
    if ctx.version_code < wanted:
        got = ctx.info.get("GL_VERSION", str(ctx.version_code))
        ctx.release()
        if lib is not None:
            _egl_restore(lib, saved)
        raise GLUnavailableError(
            f"OpenGL >= {major}.{minor} needed, the driver provides {got}; {INSTALL_HINT}"
        )
    return ctx


_EGL_DRAW, _EGL_READ = 0x3059, 0x305A


@functools.lru_cache(maxsize=1)
def _egl():
    import ctypes

    try:
        lib = ctypes.CDLL("libEGL.so.1")
    except OSError:
        return None
    for name in ("eglGetCurrentDisplay", "eglGetCurrentContext", "eglGetCurrentSurface"):
        getattr(lib, name).restype = ctypes.c_void_p
    lib.eglGetCurrentSurface.argtypes = [ctypes.c_int32]
    lib.eglMakeCurrent.argtypes = [ctypes.c_void_p] * 4
    lib.eglMakeCurrent.restype = ctypes.c_uint32
    return lib


def _egl_saved(lib) -> tuple:
    return (
        lib.eglGetCurrentDisplay(),
        lib.eglGetCurrentSurface(_EGL_DRAW),
        lib.eglGetCurrentSurface(_EGL_READ),
        lib.eglGetCurrentContext(),
    )


def _egl_restore(lib, saved: tuple) -> None:
    # Nothing was current before (display/context null): leave things as they are.
    if saved[0] and saved[3]:
        lib.eglMakeCurrent(*saved)


@contextlib.contextmanager
def headless_context(*, require=(3, 3), backend: str = "egl") -> Iterator[Any]:
    """A temporary headless context, released afterwards; the EGL context that was current
    before (e.g. a caller's own moderngl context) is made current again, because creating
    and releasing a context would otherwise leave the caller's GL calls going nowhere."""
    lib = _egl() if backend == "egl" else None
    saved = None
    if lib is not None:
        saved = (
            lib.eglGetCurrentDisplay(),
            lib.eglGetCurrentSurface(_EGL_DRAW),
            lib.eglGetCurrentSurface(_EGL_READ),
            lib.eglGetCurrentContext(),
        )
    ctx = create_headless_context(require=require, backend=backend)
    try:
        yield ctx
    finally:
        ctx.release()
        if lib is not None and saved[0] and saved[3]:
            lib.eglMakeCurrent(*saved)


@functools.lru_cache(maxsize=1)
def _gl_flush():
    try:
        from OpenGL import platform
    except ImportError:  # PyOpenGL comes with the "render" extra
        return None
    # the GL library's own entry point: PyOpenGL's wrappers (raw ones too) check
    # glGetError afterwards and would blame an earlier call's pending error on the flush
    return platform.PLATFORM.GL.glFlush


def flush_commands() -> bool:
    """Hand the GL commands issued so far on the current context to the driver without
    waiting for them (``glFlush``, which moderngl does not expose); False when PyOpenGL is
    missing (nothing is flushed early, the frame is the same).

    On llvmpipe a draw call shades its vertices and bins its triangles in the calling
    thread, and the rasteriser threads start on the binned triangles only at a flush: a
    flush part-way through a frame lets them rasterise the first part while this thread
    shades the vertices of the rest.
    """
    fn = _gl_flush()
    if fn is None:
        return False
    fn()
    return True


_DEPTH: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_EGL_HANDLE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@contextlib.contextmanager
def current(ctx) -> Iterator[Any]:
    """Make ``ctx`` the current GL context for the block, then restore the previous one.

    moderngl does not switch contexts by itself: once another context was created or released
    in the process, GL calls on ``ctx`` would go to the wrong (or no) context and silently
    draw nothing. ``with ctx:`` is not enough: glcontext's EGL exit makes *no* context
    current. So the EGL state is saved and restored here (plain ``with ctx`` when libEGL
    cannot be loaded).

    Re-entrant: a block inside another block of ``ctx`` costs nothing while ``ctx`` is still
    current. For an EGL context that is checked, not assumed — code in the outer block may
    have created or released another context, which makes that one current.
    """
    depth = _DEPTH.get(ctx, 0)
    lib = _egl()
    handle = _EGL_HANDLE.get(ctx) if lib is not None else None
    if depth and (handle is None or lib.eglGetCurrentContext() == handle):
        _DEPTH[ctx] = depth + 1
        try:
            yield ctx
        finally:
            _DEPTH[ctx] = depth
        return
    if lib is None:
        with ctx:
            _DEPTH[ctx] = depth + 1
            try:
                yield ctx
            finally:
                _DEPTH[ctx] = depth
        return
    saved = _egl_saved(lib)
    ctx.__enter__()
    # a window's GLX context has no EGL handle (None): nested blocks then trust the depth
    _EGL_HANDLE[ctx] = lib.eglGetCurrentContext() or None
    _DEPTH[ctx] = depth + 1
    try:
        yield ctx
    finally:
        _DEPTH[ctx] = depth
        _egl_restore(lib, saved)


def with_current_context(method):
    """Decorate a method of a renderer holding ``self.ctx`` so that it runs with that context
    made current (:func:`current`). moderngl does not switch contexts by itself: after another
    context was created or released in the process, the renderer's GL calls would otherwise
    go to the wrong (or no) context, and a program compiled earlier would name another
    context's object — frames silently empty or wrong."""

    @functools.wraps(method)
    def wrapper(self, *args, **kwargs):
        # __init__ runs before self.ctx exists: the context is its first argument then.
        with current(self.__dict__.get("ctx") or args[0]):
            return method(self, *args, **kwargs)

    return wrapper


def describe_context(ctx) -> dict:
    """Renderer, version, vendor and the limits the renderer checks against.

    Returns a plain dict (JSON-serialisable) with keys ``renderer``, ``vendor``, ``version``,
    ``version_code``, ``max_texture_size``, ``max_3d_texture_size``,
    ``max_array_texture_layers``, ``max_viewport_dims``, ``max_samples``,
    ``max_texture_units``.
    """
    info = ctx.info

    def get(key, default=None):
        value = info.get(key, default)
        return tuple(int(v) for v in value) if isinstance(value, tuple) else value

    return {
        "renderer": get("GL_RENDERER", "unknown"),
        "vendor": get("GL_VENDOR", "unknown"),
        "version": get("GL_VERSION", "unknown"),
        "version_code": int(ctx.version_code),
        "max_texture_size": int(get("GL_MAX_TEXTURE_SIZE", 0)),
        "max_3d_texture_size": int(get("GL_MAX_3D_TEXTURE_SIZE", 0)),
        "max_array_texture_layers": int(get("GL_MAX_ARRAY_TEXTURE_LAYERS", 0)),
        "max_viewport_dims": get("GL_MAX_VIEWPORT_DIMS", (0, 0)),
        "max_samples": int(get("GL_MAX_SAMPLES", 0)),
        "max_texture_units": int(get("GL_MAX_COMBINED_TEXTURE_IMAGE_UNITS", 0)),
    }


__all__ = [
    "INSTALL_HINT",
    "create_headless_context",
    "current",
    "describe_context",
    "headless_context",
    "with_current_context",
]
