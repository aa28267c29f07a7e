"""The interactive window (moderngl-window 3, pyglet backend): events → :class:`ViewerSession`.

Janković 2010 §2.6.4: an event receiver records which keys are down, the main loop moves the
FPS camera and changes the shader parameters from them, draws the scene with its sky box and
the GUI text, until the window closes. Here the event receiver is :class:`ViewerWindow`
(a ``WindowConfig``), the parameters live in :class:`~terrascape.viewer.controls.ViewerState`
and the frame is drawn by :class:`~terrascape.viewer.session.ViewerSession`.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.viewer.controls import Action
from terrascape.viewer.resolution import DEFAULT_TARGET_FPS
from terrascape.viewer.session import KeyRepeat, ViewerSession

HEADLESS_HINT = "for headless use run `terrascape render`"
ISO_LEFT_TAB = 0xFE20  # X11 sends Shift+Tab as ISO_Left_Tab


def check_display() -> None:
    """Raise :class:`GLUnavailableError` when no window can be opened (no X display).

    On Linux a window needs an X server (``DISPLAY``; Wayland sessions provide XWayland);
    other platforms always have a desktop.
    """
    if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        raise GLUnavailableError(
            f"no display (DISPLAY is unset); {HEADLESS_HINT}"
        )


def pictures_dir(home: Path | None = None, environ: dict[str, str] | None = None) -> Path | None:
    """The user's pictures folder: ``XDG_PICTURES_DIR`` (environment, then
    ``~/.config/user-dirs.dirs``), else ``~/Pictures``; ``None`` when none exists."""
    env = os.environ if environ is None else environ
    home = Path.home() if home is None else home
    candidates = [env.get("XDG_PICTURES_DIR", "")]
    config = Path(env.get("XDG_CONFIG_HOME") or home / ".config") / "user-dirs.dirs"
    with contextlib.suppress(OSError, UnicodeDecodeError):
        for line in config.read_text(encoding="utf-8").splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "XDG_PICTURES_DIR":
                candidates.append(value.strip().strip('"').replace("$HOME", str(home)))
    candidates.append(str(home / "Pictures"))
    for candidate in candidates:
        if candidate and Path(candidate).is_dir() and Path(candidate) != home:
            return Path(candidate)
    return None


def default_screenshot_dir(heightmap_path: str | os.PathLike | None = None, *,
                           home: Path | None = None,
                           environ: dict[str, str] | None = None) -> Path:
    """Where F12 screenshots go unless ``--screenshot-dir`` says otherwise:
    ``<pictures>/terrascape`` (:func:`pictures_dir`), else a ``screenshots`` folder next to
    the heightmap file, else ``./screenshots``. The folder is created on the first F12."""
    pictures = pictures_dir(home, environ)
    if pictures is not None:
        return pictures / "terrascape"
    if heightmap_path is not None:
        return Path(heightmap_path).resolve().parent / "screenshots"
    return Path.cwd() / "screenshots"


def key_names(keys_cls) -> dict[int, str]:
    """Window-library key code → controls key name (``"W"``, ``"TAB"``, ``"F1"``, …)."""
    names: dict[int, str] = {}
    for name in dir(keys_cls):
        if name.isupper() and not name.startswith("ACTION_"):
            value = getattr(keys_cls, name)
            if isinstance(value, int):
                names.setdefault(value, name)
    names.setdefault(ISO_LEFT_TAB, "TAB")
    return names


def _window_config_base():
    from moderngl_window import WindowConfig

    return WindowConfig


def make_window_config():
    """The :class:`ViewerWindow` class (built lazily so importing this module never needs
    moderngl-window or a display)."""
    base = _window_config_base()

    class ViewerWindow(base):
        """Event receiver + main loop body of the viewer."""

        title = "terrascape view"
        gl_version = (3, 3)
        aspect_ratio = None  # use the whole window, whatever its shape
        vsync = False
        clear_color = None  # the renderer clears (sky colour)

        def __init__(self, session: ViewerSession, *, screenshot_dir: Path,
                     max_frames: int = 0, **kwargs: Any) -> None:
            super().__init__(**kwargs)
            self.session = session
            self.screenshot_dir = Path(screenshot_dir)
            self.max_frames = int(max_frames)
            self.names = key_names(self.wnd.keys)
            self.keys_down: set[str] = set()
            self.repeat = KeyRepeat()
            self.wnd.exit_key = None  # Esc is ours: release the mouse first, then quit
            self.shift = False
            self.want_screenshot = False

        # --- main loop body -------------------------------------------------------------
        def on_render(self, time_s: float, frame_time: float) -> None:
            s = self.session
            now = time.monotonic()
            for key in self.repeat.due(now):
                self._apply(s.state.handle_key(key, shift=self.shift))
            fast = self.shift or bool({"LEFT_SHIFT", "RIGHT_SHIFT"} & self.keys_down)
            s.advance(frame_time, self.keys_down, fast=fast)
            # a screenshot's frame is drawn at full size, moving or not
            s.render(self.wnd.fbo, frame_time, full_size=self.want_screenshot)
            if self.want_screenshot:
                # Read the back buffer now, before the swap leaves it undefined.
                self.want_screenshot = False
                self.screenshot_dir.mkdir(parents=True, exist_ok=True)
                path = s.screenshot(self.wnd.fbo, self.screenshot_dir)
                print(f"screenshot: {path}", file=sys.stderr, flush=True)
            if self.max_frames and s.frames >= self.max_frames:
                self.wnd.close()

        # --- events ---------------------------------------------------------------------
        def on_key_event(self, key, action, modifiers) -> None:
            name = self.names.get(key)
            self.shift = bool(getattr(modifiers, "shift", False))
            if name is None:
                return
            if action == self.wnd.keys.ACTION_PRESS:
                self.keys_down.add(name)
                self.repeat.press(name, time.monotonic())
                self._apply(self.session.state.handle_key(name, shift=self.shift))
            elif action == self.wnd.keys.ACTION_RELEASE:
                self.keys_down.discard(name)
                self.repeat.release(name)

        def _apply(self, action: Action) -> None:
            if action is Action.QUIT:
                self.wnd.close()
            elif action is Action.RELEASE_MOUSE:
                self._capture(False)
            elif action is Action.SCREENSHOT:
                self.want_screenshot = True

        def _capture(self, on: bool) -> None:
            self.session.state.mouse_captured = on
            self.wnd.mouse_exclusivity = on
            self.wnd.cursor = not on

        def on_mouse_press_event(self, x: int, y: int, button: int) -> None:
            if not self.session.state.mouse_captured:
                self._capture(True)

        def on_mouse_position_event(self, x: int, y: int, dx: int, dy: int) -> None:
            self.session.look(dx, dy)

        def on_mouse_drag_event(self, x: int, y: int, dx: int, dy: int) -> None:
            self.session.look(dx, dy)

        def on_mouse_scroll_event(self, x_offset: float, y_offset: float) -> None:
            self.session.state.scroll(y_offset)

        def on_close(self) -> None:
            self.keys_down.clear()

    return ViewerWindow


def open_window(size: tuple[int, int], *, fullscreen: bool = False, title: str = "terrascape view",
                visible: bool = True):
    """Open a pyglet window with an OpenGL 3.3 core context (moderngl-window)."""
    check_display()
    try:
        from moderngl_window.context.pyglet import Window
    except Exception as exc:  # ImportError, or pyglet failing to reach the display
        raise GLUnavailableError(
            f"cannot open a window ({type(exc).__name__}: {exc}); {HEADLESS_HINT}"
        ) from None
    try:
        # Not resizable: the renderer draws to the default framebuffer at its creation size.
        return Window(title=title, size=tuple(size), fullscreen=fullscreen, resizable=False,
                      visible=visible, gl_version=(3, 3), aspect_ratio=None, vsync=False,
                      samples=0, cursor=True)
    except Exception as exc:  # NoSuchDisplayException, GL context errors
        raise GLUnavailableError(
            f"cannot open an OpenGL 3.3 window ({type(exc).__name__}: {exc}); {HEADLESS_HINT}"
        ) from None


def run_viewer(heightmap: Heightmap, *, size: tuple[int, int] = (1280, 720),
               fullscreen: bool = False, technique: str = "plain", lod: str = "none",
               texture: np.ndarray | None = None, exaggeration: float = 1.0,
               screenshot_dir: str | os.PathLike | None = None, max_frames: int = 0,
               hud: bool = True, sea_level: float | None = None, sky_clock=None,
               objects=None, object_shadows: str | None = None, world=None,
               target_fps: float = DEFAULT_TARGET_FPS) -> int:
    """Open the viewer window and fly over ``heightmap`` until Esc / the window is closed.

    Parameters
    ----------
    heightmap
        The terrain.
    size
        Window size ``(width, height)`` in pixels (ignored when ``fullscreen``).
    technique, lod
        Start texturing technique and LOD mode (both switchable at run time: Tab, L).
    texture
        Optional ``uint8 (H, W, 3)`` colour texture stretched over the terrain.
    screenshot_dir
        Where F12 writes PNG screenshots (created on the first one); default
        :func:`default_screenshot_dir` (the user's pictures folder).
    max_frames
        Quit after this many frames (0: run until closed) — for scripted runs.
    objects, object_shadows
        :class:`~terrascape.objects.model.Instances` on the terrain (B shows/hides them)
        and their start shadow mode (G cycles cascades / volumes / none).
    world
        ``(store path, WorldBudget, TilePyramid)`` of a world streamed by tiles
        (:mod:`terrascape.render.tiled_terrain`); ``heightmap`` is then its overview.
    target_fps
        Frame rate held while the camera moves by drawing smaller frames and enlarging
        them (:mod:`terrascape.viewer.resolution`); 0: always full size.

    Returns
    -------
    int
        Number of frames drawn.

    Raises
    ------
    GLUnavailableError
        No display, or no OpenGL 3.3 window could be created (the message points to
        ``terrascape render`` for headless use).
    """
    import moderngl_window

    from terrascape.viewer.controls import LOD_MODES

    if lod not in LOD_MODES:
        raise InvalidParameterError(f"lod must be one of {', '.join(LOD_MODES)}, got {lod!r}")
    if screenshot_dir is None:
        screenshot_dir = default_screenshot_dir(heightmap.metadata.get("source"))
    print(f"F12 saves screenshots to {screenshot_dir}", file=sys.stderr, flush=True)
    wnd = open_window(size, fullscreen=fullscreen)
    session = None
    try:
        moderngl_window.activate_context(window=wnd)
        geometry = None
        if world is not None:
            from terrascape.render.tiled_terrain import stream_world

            path, share, pyramid = world
            geometry = stream_world(wnd.ctx, path, budget_bytes=share.tile_bytes,
                                    reader_bytes=share.reader_bytes, exaggeration=exaggeration,
                                    pyramid=pyramid)
        session = ViewerSession(wnd.ctx, heightmap, size=wnd.buffer_size, technique=technique,
                                lod=lod, texture=texture, exaggeration=exaggeration, hud=hud,
                                sea_level=sea_level, sky_clock=sky_clock, objects=objects,
                                geometry=geometry, target_fps=target_fps)
        if object_shadows is not None:
            session.state.object_shadows = object_shadows
        if geometry is not None:
            from terrascape.render.tiled_terrain import freeze_heap

            freeze_heap()  # no full collection of the set-up's objects inside a frame
        cls = make_window_config()
        config = cls(session, screenshot_dir=Path(screenshot_dir), max_frames=max_frames,
                     ctx=wnd.ctx, wnd=wnd)
        wnd.config = config
        wnd.swap_buffers()
        wnd.set_default_viewport()
        from moderngl_window.timers.clock import Timer

        timer = Timer()
        timer.start()
        while not wnd.is_closing:
            t, dt = timer.next_frame()
            wnd.use()
            wnd.render(t, dt)
            if not wnd.is_closing:
                wnd.swap_buffers()
        timer.stop()
        return session.frames
    finally:
        if session is not None:
            session.release()
        wnd.destroy()
        with contextlib.suppress(Exception):  # pyglet: make sure the X window goes away
            wnd._window.close()


__all__ = ["HEADLESS_HINT", "check_display", "default_screenshot_dir", "key_names",
           "make_window_config", "open_window", "pictures_dir", "run_viewer"]
