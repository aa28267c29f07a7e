"""Viewer frame rates per technique (Janković 2010 §2.7 FPS table; Filipović 2008 §5.3 with ROAM).

Every frame is what ``terrascape view`` does per frame — LOD update, sky + terrain, HUD text,
buffer swap — on a seeded camera flight at 1280×720: once with the full-resolution mesh
(frustum-culled chunks) and once with ROAM holding 80,000 triangles (Filipović 2008 §5.2's
figure) under the viewer's per-frame split/merge time budget
(:data:`~terrascape.viewer.session.LOD_TIME_BUDGET_MS`; ROAM's queues are incremental,
Duchaineau et al. 1997, so a stopped update continues next frame). The plain technique is
also measured with no budget (ROAM converging every frame, as before), and after its flight
the last camera is held until the budgeted mesh settles: the table's notes say in how many
frames, and whether it is then the mesh an unbudgeted update makes.

Per row: frames/s over the flight, the median and 95th-percentile frame time, the median
LOD update (ROAM ms) and the median rest of the frame (draw ms: terrain, sky, water, HUD,
swap), and whether the row meets the viewer target of 15 frames/s (ROAM rows). With a
display (``DISPLAY`` set, e.g. under Xvfb) the frames go to a real moderngl-window/pyglet
window; without one, to an off-screen framebuffer of a headless EGL context (noted under the
table).

References
----------
- M. Duchaineau et al., "ROAMing terrain: real-time optimally adapting meshes", IEEE
  Visualization 1997.
"""

from __future__ import annotations

import contextlib
import math
import os
import statistics
import sys
import time
from dataclasses import replace

import numpy as np

from terrascape.bench import BenchTable

SIZE = (1280, 720)
ROAM_TRIANGLES = 80_000
TARGET_FPS = 15.0
SETTLE_LIMIT = 200  # frames the last camera is held for the budgeted mesh to settle
QUICK_TECHNIQUES = ("plain", "regions", "bump", "relief")
WARMUP = 3
# Warm-up frames of a row drawn with the dynamic resolution: it finds its scale over the
# first few frames of a flight (each new scale is measured for three), as after a
# technique switch in the viewer; the row measures the flight that follows.
ADAPTIVE_WARMUP = 12
PROBE_SIZE = (128, 72)
PROBE_LIMIT_S = 0.5  # a probe frame slower than this would take minutes at 1280×720
PROBE_TIMEOUT_S = 12.0


def flight(hm, frames: int, size=SIZE, *, seed: int = 5) -> list:
    """Seeded camera flight: a circle at 0.3 of the terrain's width around its centre, high
    above the peaks, looking along the path and 20° down (the whole relief passes by).

    Integration point: when ``terrascape.bench.render`` provides ``camera_flight(hm, frames,
    size)`` (the render benchmark's flight), that one is used instead so both tables share
    their cameras.
    """
    try:  # pragma: no cover - depends on the render benchmark being present
        from terrascape.bench.render import camera_flight

        return list(camera_flight(hm, frames, size))
    except (ImportError, AttributeError, TypeError):
        pass
    from terrascape.viewer.session import start_camera

    base = start_camera(hm, size)
    rng = np.random.default_rng(seed)
    w, d = hm.extent
    radius = 0.3 * min(w, d)
    phase = rng.uniform(0.0, 2.0 * math.pi)
    height = hm.max + 0.08 * max(w, d)
    cams = []
    for k in range(frames):
        a = phase + 2.0 * math.pi * k / max(frames, 1) * 0.25  # a quarter circle
        x, z = w / 2 + radius * math.cos(a), d / 2 + radius * math.sin(a)
        yaw = math.degrees(math.atan2(-math.sin(a), -math.cos(a)))  # along the tangent
        cams.append(replace(base, position=(x, height, z), yaw=yaw, pitch=-20.0,
                            aspect=size[0] / size[1]))
    return cams


class _Surface:
    """Where frames go: a real window (``present`` swaps buffers) or an off-screen FBO."""

    def __init__(self, size) -> None:
        self.window = None
        self.note = ""
        if os.environ.get("DISPLAY") or not sys.platform.startswith("linux"):
            try:
                from terrascape.viewer.app import open_window

                self.window = open_window(size, title="terrascape bench viewer")
            except Exception as exc:  # no usable display: measure headless instead
                self.note = f"window failed ({str(exc).splitlines()[0]}); "
        if self.window is not None:
            self.ctx = self.window.ctx
            self.fbo = self.window.fbo
            self.note += (f"real window (moderngl-window/pyglet) on DISPLAY="
                          f"{os.environ.get('DISPLAY', '?')}, framebuffer "
                          f"{self.fbo.size[0]}×{self.fbo.size[1]}")
        else:
            from terrascape.render.context import headless_context

            # released through headless_context: a caller's own GL context is current again
            self._gl = contextlib.ExitStack()
            self.ctx = self._gl.enter_context(headless_context())
            self.fbo = self.ctx.simple_framebuffer(size)
            self.note += "no display: headless EGL context, off-screen framebuffer"
        self.renderer = self.ctx.info.get("GL_RENDERER", "?")

    def present(self) -> None:
        if self.window is not None:
            self.window.swap_buffers()
        else:
            self.ctx.finish()

    def release(self) -> None:
        if self.window is not None:
            self.window.close()
            self.window.destroy()
        else:
            self.fbo.release()
            self._gl.close()


_PROBE_CODE = """
import sys, time
from terrascape.bench.viewer import PROBE_SIZE, SIZE, flight
from terrascape.generate.registry import generate
from terrascape.render.context import create_headless_context
from terrascape.viewer.session import ViewerSession
n, frames, tech = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
hm = generate("diamond-square", n, seed=1, spacing=2.0)
ctx = create_headless_context()
s = ViewerSession(ctx, hm, size=SIZE, hud=False, warn=lambda m: None)
s.camera = flight(hm, frames)[0]
s.state.technique = tech
fbo = ctx.simple_framebuffer(PROBE_SIZE)
s.render(fbo, 0.0)
ctx.finish()
t0 = time.perf_counter()
s.render(fbo, 0.0)
ctx.finish()
print(s.state.technique, time.perf_counter() - t0)
"""


def _probe(n: int, frames: int, tech: str, timeout: float) -> tuple[str, float]:
    """Render one small frame of ``tech`` from the flight's first camera in a child process.

    A GL draw cannot be interrupted, and some shaders take minutes per frame on software GL
    at grazing view angles; the child is killed after ``timeout`` seconds. Returns
    ``("ok", seconds)``, ``("fallback", 0)`` (the technique failed and plain was used) or
    ``("timeout", timeout)``.
    """
    import subprocess

    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE_CODE, str(n), str(frames), tech],
                              capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return "timeout", timeout
    if proc.returncode != 0:
        return "error: " + (proc.stderr.strip().splitlines() or ["?"])[-1], 0.0
    used, seconds = proc.stdout.split()[-2:]
    return ("ok" if used == tech else "fallback"), float(seconds)


def _measure(session, surface, cams, warmup: int = WARMUP) -> dict:
    """Frames of the flight after ``warmup`` frames of its start: frame time, the LOD
    update's share (``session.lod.last_ms``: the scheme's update and its triangle list) and
    the rest (draw)."""
    times, tris, lod_ms, scales = [], [], [], []
    last = time.perf_counter()
    for k, cam in enumerate([*cams[:warmup], *cams]):
        session.camera = cam
        t0 = time.perf_counter()
        session.render(surface.fbo, t0 - last)
        surface.present()
        last = time.perf_counter()
        if k >= warmup:
            times.append(last - t0)
            tris.append(session.stats.get("triangles", 0))
            lod_ms.append(session.lod.last_ms if session.state.lod != "none" else 0.0)
            scales.append(session.drawn_scale)
    frame_ms = np.array(times) * 1000.0
    draw_ms = frame_ms - np.array(lod_ms)
    return {
        "fps": len(times) / sum(times),
        "median_ms": float(np.median(frame_ms)),
        "p95_ms": float(np.percentile(frame_ms, 95)),
        "triangles": int(np.mean(tris)),
        "lod_ms": float(np.median(lod_ms)),
        "draw_ms": float(np.median(draw_ms)),
        "scale": float(np.median(scales)),
    }


def settle_frames(session, surface, camera, limit: int = SETTLE_LIMIT) -> int | None:
    """Frames drawn from a held ``camera`` until the session's LOD update settles (ROAM no
    longer stopped by its time budget); None if it did not within ``limit`` frames."""
    session.camera = camera
    for k in range(1, limit + 1):
        session.render(surface.fbo, 0.0)
        surface.present()
        if session.lod.settled:
            return k
    return None


def _unbudgeted_keeps(session, camera, size) -> bool:
    """Whether an unbudgeted ROAM update for ``camera``, run on a copy of the session's
    settled mesh, leaves it as it is (the budget only spread the work over frames)."""
    import copy

    roam = session.lod._schemes["roam"]
    twin = copy.deepcopy(roam)
    twin.update(replace(camera, aspect=size[0] / size[1]), size,
                **session.state.lod_update_settings())
    return bool(np.array_equal(roam.triangles(), twin.triangles()))


# One terrain program with every lighting branch and the cascade lookup compiled in (what
# every frame ran before each program was compiled for its frame's lighting).
EVERY_BRANCH = {"TERRAIN_LIGHTING": "u_lighting", "TERRAIN_CASCADES": 1,
                "TERRAIN_VERTEX_HAZE": 0}


def _measure_row(session, surface, cams, table, tech: str, lod: str, budget, label: str, *,
                 adaptive: bool) -> tuple[dict, int | None]:
    """Fly ``cams`` with ``tech`` and LOD mode ``lod`` (ROAM time ``budget``), with the
    dynamic resolution when ``adaptive``, and add the row to ``table``. Returns the
    measurement and in how many frames the first camera's mesh settled (None: it did not,
    or no LOD)."""
    from terrascape.viewer.resolution import ResolutionControl

    session.state.technique, session.state.lod = tech, lod
    session.lod.time_budget_ms = budget
    session.resolution = ResolutionControl(target_fps=TARGET_FPS if adaptive else 0.0)
    built = None
    if lod != "none":
        # the flight starts from the first camera's settled mesh (steady state), not from a
        # mesh still building up under the budget
        built = settle_frames(session, surface, cams[0])
    t0 = time.perf_counter()
    r = _measure(session, surface, cams, ADAPTIVE_WARMUP if adaptive else WARMUP)
    print(f"bench viewer: {tech} {label}: {r['fps']:.1f} frames/s, ROAM {r['lod_ms']:.1f} ms, "
          f"draw {r['draw_ms']:.1f} ms per frame at {r['scale']:.0%} size "
          f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    met = ("met" if r["fps"] >= TARGET_FPS else "missed") if adaptive else "-"
    table.rows.append([tech, label, f"{r['scale']:.0%}", round(r["fps"], 1),
                       round(r["median_ms"], 1), round(r["p95_ms"], 1),
                       round(r["lod_ms"], 1) if lod != "none" else "-",
                       round(r["draw_ms"], 1), f"{r['triangles']:,}", met])
    return r, built


def _shading_table(session, surface, cams, n: int) -> BenchTable:
    """The plain daylight frame's draw (ROAM triangles set, no LOD update, no HUD),
    interleaved frame by frame: the program compiled for the frame's lighting mode against
    the one with every branch."""
    from terrascape.render.techniques import get_technique

    tech = get_technique("plain")
    before = replace(tech, defines={**(tech.defines or {}), **EVERY_BRANCH})
    variants = {"compiled for its lighting mode, haze per vertex": tech,
                "every branch, haze per pixel (before)": before}
    times: dict[str, list[float]] = {k: [] for k in variants}
    session.state.technique, session.state.lod = "plain", "roam"
    budget, session.lod.time_budget_ms = session.lod.time_budget_ms, None  # each camera's mesh
    params = session.frame_params("plain")
    for k, cam in enumerate(cams):
        session.camera = cam
        session.render(surface.fbo, 0.0)  # the LOD for this camera
        surface.present()
        for label, variant in variants.items():
            t0 = time.perf_counter()
            session.renderer.render(surface.fbo, replace(cam, aspect=SIZE[0] / SIZE[1]),
                                    variant, params)
            surface.present()
            if k >= 1:  # the first camera compiles both programs
                times[label].append(time.perf_counter() - t0)
    session.lod.time_budget_ms = budget
    table = BenchTable(
        f"Plain daylight draw, ROAM {ROAM_TRIANGLES // 1000}k, {SIZE[0]}×{SIZE[1]}, "
        f"diamond-square {n}×{n}: shading programs, interleaved",
        ["program", "draws/s", "median ms"])
    for label, ts in times.items():
        table.rows.append([label, round(len(ts) / sum(ts), 1),
                           round(statistics.median(ts) * 1000.0, 1)])
    table.notes.append("the terrain, sky and water passes only (no LOD update, HUD or swap); "
                       "a software rasteriser runs every branch of a shader on every pixel")
    return table


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.render.techniques import technique_names
    from terrascape.viewer.session import LOD_TIME_BUDGET_MS, ViewerSession, ordered_techniques

    n = 257 if quick else 513
    frames = 10 if quick else 24
    hm = generate("diamond-square", n, seed=1, spacing=VIEW_SPACING)
    techniques = QUICK_TECHNIQUES if quick else ordered_techniques(technique_names())
    cams = flight(hm, frames)
    surface = _Surface(SIZE)
    notes: list[str] = []
    session = ViewerSession(surface.ctx, hm, size=SIZE, hud=True,
                            lod_time_budget_ms=LOD_TIME_BUDGET_MS, warn=notes.append,
                            target_fps=TARGET_FPS)
    session.state.triangle_target = ROAM_TRIANGLES
    roam_label = f"ROAM {ROAM_TRIANGLES // 1000}k"
    table = BenchTable(
        f"Viewer frame rate per technique, {SIZE[0]}×{SIZE[1]}, diamond-square {n}×{n} "
        f"({frames}-frame flight)",
        ["technique", "mesh", "drawn at", "frames/s", "median ms", "p95 ms", "ROAM ms",
         "draw ms", "triangles", f"≥ {TARGET_FPS:g} frames/s"],
    )
    tables = []
    try:
        tables.append(_shading_table(session, surface, cams[:6 if quick else 12], n))
        for tech in techniques:
            if tech not in session.state.available:
                continue
            status, probe = ("ok", 0.0) if tech == "plain" else _probe(
                n, frames, tech, PROBE_TIMEOUT_S)
            if status != "ok" or probe > PROBE_LIMIT_S:
                why = (f"probe frame {probe:.2f} s" if status == "ok" else
                       f"probe {status}" + (f" after {probe:.0f} s" if status == "timeout"
                                            else ""))
                table.rows.append([tech, "-", "-", "skipped", "-", "-", "-", "-", "-", "-"])
                notes.append(f"{tech}: skipped — {why} at {PROBE_SIZE[0]}×{PROBE_SIZE[1]} "
                             "from the flight's first camera (software GL would take minutes "
                             "per 1280×720 frame)")
                continue
            # (LOD mode, ROAM time budget, label)
            budgeted = f"{roam_label}, {LOD_TIME_BUDGET_MS:g} ms budget"
            modes = [("none", None, "full"), ("roam", LOD_TIME_BUDGET_MS, budgeted)]
            if tech == "plain":
                modes.append(("roam", None, f"{roam_label}, no budget"))
            else:  # the full mesh is the plain-texturing reference only
                modes = modes[1:]
            for lod, budget, label in modes:
                # the full mesh is drawn at full size; ROAM rows with the dynamic
                # resolution, and when that drew smaller, again at full size for the record
                r, built = _measure_row(session, surface, cams, table, tech, lod, budget,
                                        label, adaptive=lod != "none")
                if r["scale"] < 1.0:
                    _measure_row(session, surface, cams, table, tech, lod, budget,
                                 f"{label}, full size", adaptive=False)
                if tech == "plain" and budget is not None:
                    notes.append(f"ROAM time budget {budget:g} ms: the first camera's mesh "
                                 + (f"settled in {built} frame(s)" if built else
                                    f"had not settled in {SETTLE_LIMIT} frames")
                                 + " before the flight")
                    held = settle_frames(session, surface, cams[-1])
                    same = held is not None and _unbudgeted_keeps(session, cams[-1], SIZE)
                    notes.append(
                        f"ROAM time budget {budget:g} ms: with the flight's last camera held, "
                        + (f"the mesh settled after {held} frame(s)" if held is not None else
                           f"the mesh had not settled after {SETTLE_LIMIT} frames")
                        + ("; an unbudgeted update leaves it unchanged" if same else
                           "; an unbudgeted update still changes it" if held else ""))
    finally:
        session.release()
        surface.release()
    table.notes += [
        surface.note + f"; GL_RENDERER {surface.renderer}",
        "per frame: LOD update (ROAM's split/merge loop stops at its time budget and "
        "continues next frame; 'no budget' converges every frame) + sky + terrain + HUD "
        "text + swap/finish; ROAM ms and draw ms are medians over the flight's frames; full "
        "= every chunk that passes frustum culling at full resolution",
        f"target: >= {TARGET_FPS:g} frames/s with ROAM 80k on llvmpipe",
        "drawn at: median share of the window's width and height the flight's frames were "
        f"drawn at (the viewer's dynamic resolution holds {TARGET_FPS:g} frames/s while the "
        "camera moves, and draws full size when it stops); a row drawn smaller is followed "
        f"by the same flight at full size; rows with the dynamic resolution start after "
        f"{ADAPTIVE_WARMUP} warm-up frames of the flight (the scale is found in about 6-9), "
        f"others after {WARMUP}",
        *notes,
    ]
    return [table, *tables]


__all__ = ["flight", "run", "settle_frames"]
