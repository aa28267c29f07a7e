"""The viewer minus the window: camera flight, LOD, technique parameters, fallback, HUD.

:class:`ViewerSession` owns a :class:`~terrascape.render.terrain.TerrainRenderer`, a
:class:`~terrascape.viewer.controls.ViewerState` and the camera, and draws one frame into
any moderngl framebuffer — the window's (``terrascape view``), or an off-screen one (tests,
benchmarks without a display). It is the thesis's main loop body (Janković 2010 §2.6.4.3: read the
held keys, update the parameters the shader constant callback sends, draw the scene, draw the
GUI text) with the free camera of Filipović 2008 §5.2 and the LOD algorithms of Filipović 2008 §4–5.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from terrascape._validate import check_positive
from terrascape.camera import Camera, frame_terrain
from terrascape.errors import InvalidParameterError, TerrascapeError
from terrascape.heightmap import Heightmap
from terrascape.lod.schemes import SCHEMES
from terrascape.render.context import with_current_context
from terrascape.viewer.controls import HELP, LOD_MODES, ViewerState, fly, look
from terrascape.viewer.resolution import ResolutionControl

# Technique cycling order (Tab): the Filipović 2008 texturing methods, then Janković 2010's relief
# family from cheapest to most expensive; techniques registered later are appended sorted.
PREFERRED_ORDER: tuple[str, ...] = (
    "material", "plain", "regions", "texture3d", "splat", "bump", "parallax", "parallax_limited",
    "steep_parallax", "pom", "relief", "interval", "cone", "minmax", "relief_by_distance",
)  # fmt: skip

DAY_HORIZON = (0.74, 0.82, 0.92)
DAY_ZENITH = (0.26, 0.46, 0.80)
DAY_SUN = (1.0, 0.95, 0.85)
NIGHT_HORIZON = (0.05, 0.06, 0.11)
NIGHT_ZENITH = (0.01, 0.015, 0.04)
NIGHT_AMBIENT = (0.22, 0.26, 0.42)  # moonlight: bluish, dim
DUSK_TINT = (0.40, 0.12, -0.10)  # added to the horizon around sunset / sunrise

# ROAM's split/merge time per frame (ms). Its queues are incremental (Duchaineau et al. 1997):
# an update stopped by the budget leaves a valid mesh and the next frames continue it, so a
# bounded update costs a frame at most this much plus the queue refresh, and a camera that
# stops gets the converged mesh a few frames later (``terrascape bench viewer`` counts them).
# At 15 frames/s (66 ms a frame) on llvmpipe the terrain draw needs the rest.
LOD_TIME_BUDGET_MS = 8.0

# Keys whose effect repeats while held (the seed polls IsKeyDown every frame for them).
REPEAT_KEYS = frozenset({
    "EQUAL", "MINUS", "RIGHT_BRACKET", "LEFT_BRACKET", "PERIOD", "COMMA",
    "O", "P", "N", "M", "PAGE_UP", "PAGE_DOWN", "Y", "U",
})  # fmt: skip


def ordered_techniques(names: Iterable[str]) -> tuple[str, ...]:
    """Registered technique names in Tab order (:data:`PREFERRED_ORDER` first)."""
    names = list(dict.fromkeys(names))
    first = [n for n in PREFERRED_ORDER if n in names]
    return tuple(first + sorted(n for n in names if n not in first))


def _lerp(a, b, t: float) -> tuple[float, ...]:
    return tuple(float(x + (y - x) * t) for x, y in zip(a, b, strict=True))


def sky_colors(daylight: float) -> dict[str, tuple[float, float, float]]:
    """Sky and light colours for a daylight factor (0 night … 1 day; ``ViewerState.daylight``).

    Day colours are the renderer's defaults; the horizon warms around sunset (the dusk tint
    peaks at ``daylight = 0.5``, i.e. the sun on the horizon) and everything fades to a dim
    blue moonlight at night.
    """
    d = float(np.clip(daylight, 0.0, 1.0))
    dusk = 4.0 * d * (1.0 - d)
    horizon = np.clip(np.add(_lerp(NIGHT_HORIZON, DAY_HORIZON, d), np.multiply(DUSK_TINT, dusk)),
                      0.0, 1.0)
    return {
        "horizon_color": tuple(float(v) for v in horizon),
        "zenith_color": _lerp(NIGHT_ZENITH, DAY_ZENITH, d),
        "sun_color": _lerp((0.0, 0.0, 0.0), _lerp(DAY_SUN, (1.0, 0.55, 0.25), dusk), d),
        "ambient_color": _lerp(NIGHT_AMBIENT, (1.0, 1.0, 1.0), d),
        "diffuse_color": _lerp((0.0, 0.0, 0.0), _lerp((1.0, 1.0, 1.0), (1.0, 0.7, 0.45), dusk),
                               d),
        "specular_color": _lerp((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), d),
    }


def technique_params(state: ViewerState, accepted: Mapping[str, Any], *,
                     has_lightmap: bool, fog_density: float | None = None,
                     time_s: float = 0.0, sea_level: float | None = None) -> dict[str, Any]:
    """Renderer parameters of one frame from the viewer state (the thesis's constant callback).

    Parameters
    ----------
    state
        Keys → values (:class:`~terrascape.viewer.controls.ViewerState`).
    accepted
        The technique's parameters (``Technique.parameters()``); names it lacks are left out.
    has_lightmap
        Whether the technique samples ``u_lightmap`` (``lighting="lightmap"`` is only
        offered to those).
    fog_density
        Fog density per world unit when fog is on (``None``: the renderer's automatic one).
    time_s
        Seconds since the viewer started (animates the water).
    sea_level
        Water surface height (heightmap units), or None.

    Notes
    -----
    The viewer's "parallax scale" (Janković 2010 §2.6.4: ``parametar``) is the relief depth
    ``depth`` of every relief technique, and ``parallax_scale`` with the bias ``-scale`` of
    the parallax ones (``h' = scale·h + bias``), so one key changes every technique alike.
    With the sun above the horizon the daylight model lights every technique (sky, haze,
    per-pixel soft shadows; the shadow key switches the shadows, the fog key the haze). A
    hand-placed sun (O/P/N/M) at or below the horizon has no daylight (cast shadows would
    cover everything); vertex lighting with the dimmed night colours is used instead. With
    the sky clock (``ViewerState.clock``) the daylight model lights the night as well:
    twilight, the moon as the key light, a dark-blue sky with stars. ``has_lightmap`` is kept
    for callers; daylight does not need a lightmap slot.
    """
    u = state.uniforms()
    p: dict[str, Any] = {}
    if "depth" in accepted:
        s = float(u["parallax_scale"])
        p["depth"] = max(s, 1e-3)  # a zero-depth relief texture has no normals to bake
        if "parallax_scale" in accepted:
            p["parallax_scale"] = s
            p["parallax_bias"] = -s
    for key in ("linear_steps", "binary_steps", "self_shadow"):
        if key in accepted:
            p[key] = u[key]
    p["wireframe"] = bool(state.wireframe)
    p["fog_density"] = fog_density if state.fog else 0.0
    el = float(state.sun_elevation)
    p["sun"] = (float(state.sun_azimuth), el)
    sky = state.sky_state()
    if sky is not None:
        p["sky_state"] = sky
    if el > 0.0 or sky is not None:
        # With the sky clock the daylight model runs through the night too (twilight,
        # moonlight, stars); a hand-placed sun below the horizon keeps the vertex look.
        p["lighting"] = "daylight"
        p["shadows"] = bool(state.lightmap)
        p["haze"] = None if state.fog else 0.0
        p["time"] = float(time_s)
        p["sea_level"] = sea_level
        # The viewer starts high above the terrain (the top of the frame below the horizon):
        # beyond the terrain's edge the haze (or the sea), as the sky colour was before.
        p["surround"] = "fade" if sea_level is None else "sea"
    else:
        p["lighting"] = "vertex"
    p.update(sky_colors(float(u["daylight"])))
    return {k: v for k, v in p.items() if k in accepted}


def ground_height(heights: np.ndarray, spacing: tuple[float, float], x: float, z: float) -> float:
    """Bilinear terrain height at world ``(x, z)``, clamped to the map's edges."""
    rows, cols = heights.shape
    fx = min(max(x / spacing[0], 0.0), cols - 1.0)
    fz = min(max(z / spacing[1], 0.0), rows - 1.0)
    c0, r0 = min(int(fx), cols - 2) if cols > 1 else 0, min(int(fz), rows - 2) if rows > 1 else 0
    c1, r1 = min(c0 + 1, cols - 1), min(r0 + 1, rows - 1)
    tx, tz = fx - c0, fz - r0
    h = heights
    top = h[r0, c0] * (1 - tx) + h[r0, c1] * tx
    bottom = h[r1, c0] * (1 - tx) + h[r1, c1] * tx
    return float(top * (1 - tz) + bottom * tz)


def terrain_diagonal(hm: Heightmap) -> float:
    """Length of the terrain's bounding-box diagonal (world units)."""
    ex, ez = hm.extent
    return float(math.sqrt(ex * ex + ez * ez + (hm.max - hm.min) ** 2))


def start_camera(hm: Heightmap, size: tuple[int, int], *, exaggeration: float = 1.0) -> Camera:
    """Overlooking the whole terrain (``frame_terrain``), with near/far planes that also suit
    flying down to the ground and away from it."""
    scaled = hm if exaggeration == 1.0 else hm.scaled(exaggeration)
    cam = frame_terrain(scaled.extent, (scaled.min, scaled.max), azimuth=210.0,
                        elevation=35.0, fov_y=60.0, aspect=size[0] / size[1])
    diag = terrain_diagonal(scaled)
    # near/far ratio 2.5e4 keeps 24-bit depth precise to ~0.1 % of the view distance.
    return replace(cam, near=diag * 2e-4, far=diag * 5.0)


class Smoothed:
    """Exponential moving average over time (time constant ``tau`` seconds)."""

    def __init__(self, tau: float = 0.5) -> None:
        self.tau = check_positive(tau, "tau (seconds)")
        self.value: float | None = None

    def add(self, sample: float, dt: float) -> float:
        if not math.isfinite(sample):
            return self.value if self.value is not None else float("nan")
        if self.value is None:
            self.value = float(sample)
        else:
            alpha = 1.0 - math.exp(-max(dt, 0.0) / self.tau)
            self.value += alpha * (float(sample) - self.value)
        return self.value


class KeyRepeat:
    """Auto-repeat for parameter keys held down: first repeat after ``delay`` s, then every
    ``interval`` s (Janković 2010 changes its parameters every frame while the key is down)."""

    def __init__(self, delay: float = 0.35, interval: float = 1 / 15,
                 keys: frozenset[str] = REPEAT_KEYS) -> None:
        self.delay, self.interval, self.keys = delay, interval, keys
        self._held: dict[str, float] = {}

    def press(self, key: str, now: float) -> None:
        if key in self.keys:
            self._held[key] = now + self.delay

    def release(self, key: str) -> None:
        self._held.pop(key, None)

    def due(self, now: float) -> list[str]:
        """Keys whose next repeat is due (each at most once per call)."""
        out = []
        for key, when in self._held.items():
            if now >= when:
                out.append(key)
                self._held[key] = max(when + self.interval, now - self.interval)
        return out


class LodManager:
    """The viewer's LOD schemes (:data:`~terrascape.lod.schemes.SCHEMES`) over one heightmap,
    each built on first use and kept (ROAM's frame coherence, Turner's variances).

    ``update`` returns the triangles to draw (``None`` = full mesh) and whether they changed
    since the last call — the mesh is recomputed only when the view or the settings change
    (or the last update was not settled: ROAM stopped on its time budget, Turner's feedback
    still off its target).
    """

    def __init__(self, heightmap: Heightmap, *,
                 time_budget_ms: float | None = LOD_TIME_BUDGET_MS) -> None:
        self.heightmap = heightmap
        self.available = heightmap.is_pow2_plus1
        self.time_budget_ms = time_budget_ms
        self._schemes: dict[str, Any] = {}
        self._key: tuple | None = None
        self._mode = "none"
        self._pending = False
        self.last_ms = 0.0
        self.last_triangles = 0
        self.last_detail = ""

    @property
    def settled(self) -> bool:
        """False while the last update stopped on its time budget (or Turner's feedback was
        off its target): the next update with the same view still changes the mesh."""
        return not self._pending

    def why_unavailable(self) -> str:
        hm = self.heightmap
        return (f"LOD needs a square 2^n+1 heightmap, this one is {hm.cols}×{hm.rows} "
                "(restart with --pad)")

    def update(self, mode: str, camera: Camera, viewport: tuple[int, int],
               settings: Mapping[str, float | int] | None = None,
               ) -> tuple[np.ndarray | None, bool]:
        """Triangles for ``camera`` with scheme ``mode`` (or ``"none"``) and its ``update``
        keywords ``settings`` (``ViewerState.lod_update_settings()``; others ignored)."""
        if mode not in LOD_MODES:
            raise InvalidParameterError(f"LOD mode must be one of {LOD_MODES}, got {mode!r}")
        if mode == "none":
            changed = self._mode != "none"
            self._mode, self._key = "none", None
            self.last_ms = 0.0
            return None, changed
        if not self.available:
            raise InvalidParameterError(self.why_unavailable())
        entry = SCHEMES[mode]
        kwargs = {k: v for k, v in (settings or {}).items() if k in entry.parameter_names}
        key = (mode, camera.position, camera.yaw, camera.pitch, camera.fov_y, camera.aspect,
               tuple(viewport), tuple(sorted(kwargs.items())))
        if key == self._key and not self._pending:
            return None, False
        if "time_budget_ms" in entry.parameter_names:
            kwargs["time_budget_ms"] = self.time_budget_ms
        t0 = time.perf_counter()
        scheme = self._schemes.get(mode)
        if scheme is None:
            scheme = self._schemes[mode] = entry.build(self.heightmap)
        st = scheme.update(camera, viewport, **kwargs)
        self._pending = not st.settled
        tris = scheme.triangles(visible_only=entry.draw_visible_only)
        self.last_detail = st.summary
        self._key, self._mode = key, mode
        self.last_ms = (time.perf_counter() - t0) * 1000.0
        self.last_triangles = len(tris)
        return tris, True


def _stderr_warning(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr, flush=True)


class ViewerSession:
    """One terrain in the viewer: renderer + state + camera + LOD + HUD.

    Parameters
    ----------
    ctx
        moderngl context (a window's, or a standalone one).
    heightmap
        The terrain.
    size
        Initial viewport ``(width, height)`` (sets the camera's aspect; each frame uses the
        framebuffer's size).
    technique, lod
        Start technique (registered name) and LOD mode (``none`` or a name of
        :data:`~terrascape.lod.schemes.SCHEMES`: ``roam``, ``turner``, ``geomipmap``).
    texture
        Optional ``uint8 (H, W, 3)`` colour texture stretched over the terrain (replaces the
        procedural region texture of every technique that samples ``u_color_tex``).
    exaggeration
        Vertical scale.
    hud
        Draw the HUD text (frame rate, triangles, technique, camera).
    lod_time_budget_ms
        ROAM's per-frame split/merge time budget in milliseconds (default
        :data:`LOD_TIME_BUDGET_MS`; ``None``: converge every frame).
    warn
        Called once per warning (technique fallback, unavailable LOD); default: stderr.
    sea_level
        Water up to this height (heightmap units), rippling with the viewer's clock.
    sky_clock
        ``(UTC datetime, latitude, longitude or None)``: start the sky clock there, running
        (Space pauses it); None: the sun keys' fixed sun until a time key starts a clock.
    moving_sun_shadows
        Shadows of a moved sun without a stall (coarse at once, exact from a worker
        process: :class:`~terrascape.render.sun_shadows.MovingSunShadows`); False: every sun
        change waits for the exact sweep.
    geometry
        A world streamed by tiles (:class:`~terrascape.render.tiled_terrain.TiledGeometry`,
        :func:`~terrascape.render.tiled_terrain.stream_world`) drawn instead of
        ``heightmap``'s mesh; ``heightmap`` is then the world's overview (textures,
        shadows, camera, ground). The session releases it. The LOD schemes stay off.
    target_fps
        Frame rate that moving frames are held at by drawing them at a smaller size
        (:mod:`terrascape.viewer.resolution`; the window's default is
        :data:`~terrascape.viewer.resolution.DEFAULT_TARGET_FPS`); 0 (the default here, for
        scripted frames): every frame at full size.
    """

    @with_current_context
    def __init__(self, ctx, heightmap: Heightmap, *, size: tuple[int, int] = (1280, 720),
                 technique: str = "plain", lod: str = "none", texture: np.ndarray | None = None,
                 exaggeration: float = 1.0, hud: bool = True, font_size: int | None = None,
                 lod_time_budget_ms: float | None = LOD_TIME_BUDGET_MS,
                 warn: Callable[[str], None] | None = None,
                 sea_level: float | None = None, sky_clock=None, objects=None,
                 moving_sun_shadows: bool = True, geometry=None,
                 target_fps: float = 0.0) -> None:
        from terrascape.render.techniques import TextureData, technique_names
        from terrascape.render.terrain import TerrainRenderer

        if not isinstance(heightmap, Heightmap):
            raise InvalidParameterError(
                f"expected a terrascape Heightmap, got {type(heightmap).__name__}")
        names = ordered_techniques(technique_names())
        if technique not in names:
            raise InvalidParameterError(
                f"unknown technique {technique!r}; available: {', '.join(names)}")
        if lod not in LOD_MODES:
            raise InvalidParameterError(f"--lod must be one of {', '.join(LOD_MODES)}, got {lod!r}")
        self.ctx = ctx
        self.heightmap = heightmap
        self.exaggeration = check_positive(exaggeration, "exaggeration")
        self.world = heightmap if self.exaggeration == 1.0 else heightmap.scaled(self.exaggeration)
        self.renderer = TerrainRenderer(ctx, heightmap, exaggeration=self.exaggeration)
        # the renderer's one note of a technique's fallback goes to stderr and the HUD
        self.renderer.warn = self._note
        if moving_sun_shadows:
            from terrascape.render.sun_shadows import MovingSunShadows
            from terrascape.render.techniques import COMMON_PARAMS

            # a moved sun gets coarse shadows at once and exact ones in the background,
            # instead of a frame that waits a second for the exact sweep
            self.renderer.moving_sun_shadows = MovingSunShadows(
                self.world, sun_radius_deg=COMMON_PARAMS["sun_radius"],
                samples=COMMON_PARAMS["shadow_samples"])
        self.state = ViewerState(technique=technique, lod=lod, available=names,
                                 parallax_scale=0.05)
        diag = terrain_diagonal(self.world)
        self.state.speed = diag / 8.0  # cross the terrain in ~8 s
        self.clearance = 3.0 * max(heightmap.spacing)
        # Lighter than the renderer's automatic fog: seen from the start camera (about 1.3
        # diagonals away) the terrain keeps ~80 % of its colour, exp(-(0.35·1.3)²).
        self.fog_density = 0.35 / diag
        self.camera = start_camera(heightmap, size, exaggeration=self.exaggeration)
        self.lod = LodManager(self.world, time_budget_ms=lod_time_budget_ms)
        self.frame_ms = Smoothed(0.5)
        self.lod_ms = Smoothed(0.5)
        self.warn = warn or _stderr_warning
        self._warned: set[str] = set()
        self.sea_level = sea_level
        self._start = time.monotonic()
        self._messages: list[tuple[str, float]] = []
        self.stats: dict[str, int] = {}
        self.frames = 0
        self._lod_drawn = False
        self.renderer.set_objects(objects)
        self.state.has_objects = objects is not None
        if texture is not None:
            self.renderer.set_texture("u_color_tex", TextureData(np.asarray(texture),
                                                                repeat=False))
        self.hud = None
        if hud:
            from terrascape.viewer.hud import HudRenderer

            if font_size is None:  # small windows get a smaller font
                font_size = 14 if size[1] >= 600 else (12 if size[1] >= 400 else 10)
            self.hud = HudRenderer(ctx, font_size=font_size)
        if sky_clock is not None:
            when, lat, lon = sky_clock
            self.state.set_clock(when, lat, 0.0 if lon is None else lon, running=True)
        if lod != "none" and not self.lod.available:
            self._note(self.lod.why_unavailable())
            self.state.lod = "none"
        self.geometry = geometry
        self.tile_stats: dict[str, Any] = {}
        # dynamic resolution of moving frames; still frames are drawn at full size
        self.resolution = ResolutionControl(target_fps=target_fps)
        self._scaled = None  # ScaledTarget, made on the first scaled frame
        self._last_camera: Camera | None = None
        self._last_scale: float | None = None  # scale of the previous moving frame
        self._last_start: float | None = None  # when the previous frame began
        self.clock: Callable[[], float] = time.perf_counter  # of the frame times
        self._scaled_technique = technique  # the look the scale was found for
        self._stencil_of: dict[tuple, bool] = {}
        self.drawn_scale = 1.0
        if geometry is not None:
            self.renderer.geometry = geometry
            self.state.lod = "none"

    # --- messages ------------------------------------------------------------------------
    def _note(self, message: str, seconds: float = 5.0, *, warn: bool = True) -> None:
        """Warn once on stderr and show the message on the HUD for a few seconds."""
        if warn and message not in self._warned:
            self._warned.add(message)
            self.warn(message)
        self._messages.append((message, time.monotonic() + seconds))

    # --- input ---------------------------------------------------------------------------
    def ground(self, x: float, z: float) -> float:
        return ground_height(self.world.heights, self.world.spacing, x, z)

    def advance(self, dt: float, keys_down: set[str], *, fast: bool = False) -> None:
        """Fly the camera for ``dt`` seconds with the held keys (the free camera of
        Filipović 2008 §5.2)."""
        dt = float(min(max(dt, 0.0), 0.25))  # a stalled frame must not teleport the camera
        self.camera = fly(self.camera, keys_down, dt, self.state.speed, fast=fast,
                          ground=self.ground, clearance=self.clearance,
                          follow=self.state.terrain_following)

    def look(self, dx: float, dy: float) -> None:
        """Mouse look by ``dx``, ``dy`` pixels (only while the mouse is captured)."""
        if self.state.mouse_captured:
            self.camera = look(self.camera, dx, dy)

    # --- frame ---------------------------------------------------------------------------
    def frame_params(self, technique: str | None = None) -> dict[str, Any]:
        from terrascape.render.techniques import get_technique

        tech = get_technique(technique or self.state.technique)
        has_lm = any(s.uniform == "u_lightmap" for s in tech.textures)
        p = technique_params(self.state, tech.parameters(), has_lightmap=has_lm,
                             fog_density=self.fog_density,
                             time_s=time.monotonic() - self._start,
                             sea_level=self.sea_level)
        if self.state.has_objects:
            p["object_shadows"] = self.state.object_shadows
            self.renderer.objects.enabled = self.state.objects  # B hides, keeps the buffers
        return p

    def _update_lod(self, camera: Camera, viewport: tuple[int, int]) -> None:
        st = self.state
        try:
            tris, changed = self.lod.update(st.lod, camera, viewport,
                                            st.lod_update_settings())
        except InvalidParameterError as exc:
            self._note(str(exc))
            st.lod = "none"
            tris, changed = self.lod.update("none", camera, viewport)
        if changed:
            self.renderer.set_indices(tris)

    @with_current_context
    def render(self, fbo, dt: float = 0.0, *, full_size: bool = False) -> dict[str, int]:
        """Draw one frame (LOD update, sky + terrain, HUD) into ``fbo``.

        ``dt`` is the time since the previous frame (seconds), for the smoothed frame rate
        and the dynamic resolution: while the camera moves, the frame is drawn at
        :attr:`resolution`'s scale of ``fbo``'s size and enlarged onto it
        (:mod:`terrascape.viewer.resolution`); a frame whose camera has not moved since the
        previous one, or one asked ``full_size`` (a screenshot), is drawn at full size.
        A technique this GL cannot run draws its fallback (the renderer decides and says
        so once; the session reads :attr:`~terrascape.render.terrain.TerrainRenderer.drawn`
        and takes the technique out of the Tab cycle); one whose textures or parameters
        fail on this terrain is reported once and replaced by ``plain`` (Janković 2010
        §2.6.4.3's "shaders disabled" fallback).
        """
        w, h = fbo.size
        camera = replace(self.camera, aspect=w / h)
        if dt > 0:
            self.state.advance_time(dt)
        if self.state.technique != self._scaled_technique:
            self._scaled_technique = self.state.technique
            self.resolution.restart()
        now = self.clock()
        if (dt > 0 and self._last_start is not None and self._last_scale is not None
                and self._last_scale == self.resolution.scale):
            # the previous frame was a moving one at this scale: its time is from its start
            # to this one's (drawing, buffer swap, events)
            self.resolution.update((now - self._last_start) * 1000.0)
        self._last_start = now
        moving = self._last_camera is not None and camera != self._last_camera
        self._last_camera = camera
        scale = (self.resolution.scale if moving and self.resolution.active and not full_size
                 else 1.0)
        self._last_scale = scale if moving else None
        target = fbo
        if scale < 1.0:
            if self._scaled is None:
                from terrascape.render.scaled_target import ScaledTarget

                self._scaled = ScaledTarget(self.ctx)
            target = self._scaled.target((w, h), scale, stencil=self._has_stencil(fbo))
        self.drawn_scale = scale
        if self.geometry is not None:
            if self.state.lod != "none":
                self._note("a streamed world has its own level of detail (tiles); "
                           "the LOD schemes stay off")
                self.state.lod = "none"
            # never waits: tiles still loading are drawn by their loaded parents
            self.tile_stats = self.geometry.update(camera, (w, h))
            self.lod_ms.add(self.geometry.last_update_ms, dt)
        else:
            self._update_lod(camera, (w, h))
        if self.state.lod != "none":
            self.lod_ms.add(self.lod.last_ms, dt)
        while True:
            tech = self.state.technique
            try:
                # the LOD above chose its mesh for the window's pixels, so a scaled frame
                # draws the same mesh as a full-size one
                self.stats = self.renderer.render(target, camera, tech, self.frame_params(tech))
            except TerrascapeError as exc:
                if tech == "plain":
                    raise
                self._fall_back(tech, exc)
                continue
            drawn = self.renderer.drawn
            if drawn is not None and drawn.fell_back:
                # The renderer drew the fallback and said why; stop asking for tech.
                self._drop_technique(tech, drawn.name)
            break
        if target is not fbo:
            self._scaled.present(fbo)
        if dt > 0:
            self.frame_ms.add(dt * 1000.0, dt)
        if self.hud is not None:
            self.hud.draw(fbo, self.hud_panels((w, h)))
        self.frames += 1
        return self.stats

    def _has_stencil(self, fbo) -> bool:
        """Whether the output ``fbo`` has a stencil buffer (asked once per framebuffer),
        which a smaller moving frame then gets too."""
        key = (fbo.glo, tuple(fbo.size))
        if key not in self._stencil_of:
            from terrascape.render.stencil import stencil_bits

            self._stencil_of[key] = stencil_bits(fbo) > 0
        return self._stencil_of[key]

    def _fall_back(self, tech: str, exc: Exception) -> None:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        self._note(f"technique {tech!r} cannot draw this terrain ({first}); using plain")
        self._drop_technique(tech, "plain")

    def _drop_technique(self, tech: str, instead: str) -> None:
        self.state.available = tuple(t for t in self.state.available if t != tech)
        self.state.technique = instead

    # --- HUD -----------------------------------------------------------------------------
    def status_lines(self) -> list[str]:
        """Frame rate, triangles, LOD time, technique and parameters, camera position."""
        fm = self.frame_ms.value
        fps = f"{1000.0 / fm:6.1f} fps  {fm:6.2f} ms/frame" if fm else "  -- fps"
        tris = self.stats.get("triangles", 0)
        if self.drawn_scale < 1.0:
            fps += f"  drawn at {self.drawn_scale:.0%} size while moving"
        lines = [fps, f"triangles {tris:,}"]
        if self.geometry is not None and self.tile_stats:
            t = self.tile_stats
            lines.append(f"tiles {t['tiles_drawn']} drawn, {t['tiles_loading']} loading, "
                         f"{t['tiles_resident']} resident ({t['tile_bytes'] / 2**20:.0f} MiB)  "
                         f"error ≤ {t['max_pixels']:.1f} px  update "
                         f"{self.lod_ms.value or 0.0:.1f} ms")
        if self.state.lod != "none":
            lm = self.lod_ms.value or 0.0
            lines[-1] += f"  LOD update {lm:.2f} ms  {self.lod.last_detail}"
        lines += self.state.status_lines()
        x, y, z = self.camera.eye
        lines.append(
            f"camera {x:.1f}, {y:.1f}, {z:.1f}  yaw {self.camera.yaw:.0f}° "
            f"pitch {self.camera.pitch:.0f}°  speed {self.state.speed:.3g}/s"
            + ("  [following]" if self.state.terrain_following else "")
        )
        lines.append("F1/H: help" + ("" if self.state.mouse_captured else
                                     "   click: mouse look   Esc: quit"))
        return lines

    def hud_panels(self, viewport: tuple[int, int]):
        from terrascape.viewer.hud import Panel

        panels = [Panel(self.status_lines(), "top-left")]
        if self.state.show_help:
            panels.append(Panel([f"{k}\t{d}" for k, d in HELP], "top-right",
                                background=(0.0, 0.0, 0.0, 0.65)))
        now = time.monotonic()
        self._messages = [(m, t) for m, t in self._messages if t > now]
        if self._messages:
            panels.append(Panel([m for m, _ in self._messages], "bottom-left",
                                color=(1.0, 0.85, 0.3, 1.0)))
        return panels

    # --- screenshot ----------------------------------------------------------------------
    @with_current_context
    def screenshot(self, fbo, directory: str | Path = ".") -> Path:
        """Write the framebuffer's colour to a new PNG in ``directory`` (never overwrites)."""
        from PIL import Image

        from terrascape.io.atomic import atomic_output

        directory = Path(directory)
        if not directory.is_dir():
            raise InvalidParameterError(f"screenshot directory {directory} does not exist")
        w, h = fbo.size
        raw = fbo.read(components=3, alignment=1)
        image = np.frombuffer(raw, np.uint8).reshape(h, w, 3)[::-1]
        stamp = time.strftime("%Y%m%d-%H%M%S")
        k = 0
        while (path := directory / f"terrascape-{stamp}-{k:03d}.png").exists():
            k += 1
        with atomic_output(path) as tmp:
            Image.fromarray(np.ascontiguousarray(image)).save(tmp, format="PNG")
        self._note(f"screenshot {path}", seconds=3.0, warn=False)
        return path

    @with_current_context
    def release(self) -> None:
        if self.geometry is not None:
            self.renderer.geometry = None
            self.geometry.release()
            self.geometry = None
        if self.renderer.moving_sun_shadows is not None:
            self.renderer.moving_sun_shadows.close()
        if self.hud is not None:
            self.hud.release()
        if self._scaled is not None:
            self._scaled.release()
        self.renderer.release()


__all__ = [
    "LOD_TIME_BUDGET_MS",
    "PREFERRED_ORDER",
    "KeyRepeat",
    "LodManager",
    "Smoothed",
    "ViewerSession",
    "ground_height",
    "ordered_techniques",
    "sky_colors",
    "start_camera",
    "technique_params",
    "terrain_diagonal",
]
