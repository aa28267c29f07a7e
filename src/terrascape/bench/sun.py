"""A moving sun in the viewer: per-frame times with the sun turning 1° a frame.

Two viewer sessions over the same terrain, their frames interleaved so both see the same
machine load: one recomputes the exact soft shadow map on every sun change (the viewer as it
was), the other uses :class:`~terrascape.render.sun_shadows.MovingSunShadows` (a coarse map
at once, the exact one from a worker process when the sun stops). Each frame is a full
viewer frame (sky + terrain + HUD, read back), at the same fixed camera.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from terrascape.bench import BenchTable

WARMUP = 2


def _frames(session, fbo, n: int, step_deg: float) -> list[float]:
    times = []
    for k in range(WARMUP + n):
        session.state.sun_azimuth = (120.0 + step_deg * k) % 360.0
        t0 = time.perf_counter()
        session.render(fbo, 0.05)
        fbo.read(components=3)
        if k >= WARMUP:
            times.append(time.perf_counter() - t0)
    return times


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.render.context import headless_context
    from terrascape.viewer.session import ViewerSession

    n = 513 if quick else 1025
    size = (640, 360) if quick else (1280, 720)
    frames = 8 if quick else 20
    hm = generate("diamond-square", n, seed=1, spacing=VIEW_SPACING)
    # released on the way out, the caller's own GL context made current again
    with headless_context() as ctx:
        fbo = ctx.simple_framebuffer(size)
        sessions = {
            "exact every frame": ViewerSession(ctx, hm, size=size, technique="material",
                                               moving_sun_shadows=False, warn=lambda m: None),
            "coarse while moving": ViewerSession(ctx, hm, size=size, technique="material",
                                                 moving_sun_shadows=True, warn=lambda m: None),
        }
        for s in sessions.values():
            s.state.sun_elevation = 25.0
        sessions["coarse while moving"].renderer.moving_sun_shadows.wait_ready(120.0)
        times: dict[str, list[float]] = {k: [] for k in sessions}
        still: dict[str, list[float]] = {k: [] for k in sessions}
        try:
            # interleaved: a few frames of each in turn, so load changes hit both alike
            for _ in range(max(1, frames // 4)):
                for name, s in sessions.items():
                    times[name] += _frames(s, fbo, 4, 1.0)
            for name, s in sessions.items():  # the sun stops: what the next frames cost
                still[name] = _frames(s, fbo, 3, 0.0)
        finally:
            for s in sessions.values():
                s.release()
            fbo.release()
    table = BenchTable(
        f"Viewer frames with the sun moving 1° a frame, {size[0]}×{size[1]}, material, "
        f"diamond-square {n}×{n} (interleaved)",
        ["shadows", "frames", "median ms", "p95 ms", "max ms", "max / median",
         "frames/s", "sun stops: max ms"],
    )
    for name, t in times.items():
        med = statistics.median(t)
        table.rows.append([name, len(t), med * 1000, float(np.percentile(t, 95)) * 1000,
                           max(t) * 1000, max(t) / med, len(t) / sum(t),
                           max(still[name]) * 1000])
    table.notes.append("figures from a shared, loaded 2-core machine (llvmpipe); the ratios "
                       "of the interleaved rows are what count")
    table.check_target("coarse while moving: max / median frame time",
                       table.value("coarse while moving", "max / median"), at_most=1.5)
    ratio = None
    exact = table.value("exact every frame", "median ms")
    coarse = table.value("coarse while moving", "median ms")
    if exact and coarse:
        ratio = exact / coarse
        table.notes.append(f"median frame: exact-every-frame / coarse-while-moving = "
                           f"{ratio:.2f}")
    return [table]


__all__ = ["run"]
