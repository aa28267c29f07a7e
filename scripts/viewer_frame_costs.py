"""What the viewer's dynamic resolution costs a frame, headless (EGL, llvmpipe).

    python scripts/viewer_frame_costs.py

1. The enlargement pass alone (``viewer/upscale.glsl``) from 60 % and 70 % frames onto
   1280×720: median of 20.
2. A viewer session (material, ROAM 80k, diamond-square 513²) held, then moving at 65 %,
   then held again, twice: each frame's time and size, with the deferred geometry buffers
   of two sizes kept (the default) and of one (each start and stop of the camera
   reallocates them).
"""

from __future__ import annotations

import statistics
import time

SIZE = (1280, 720)


def enlargement(ctx) -> None:
    from terrascape.render.scaled_target import ScaledTarget

    dst = ctx.simple_framebuffer(SIZE)
    target = ScaledTarget(ctx)
    for scale in (0.6, 0.7):
        target.target(SIZE, scale).use()
        ctx.clear(0.3, 0.5, 0.7)
        target.present(dst)
        ctx.finish()
        runs = []
        for _ in range(20):
            t0 = time.perf_counter()
            target.present(dst)
            ctx.finish()
            runs.append(time.perf_counter() - t0)
        print(f"enlargement from {scale:.0%} onto {SIZE[0]}×{SIZE[1]}: "
              f"{statistics.median(runs) * 1e3:.2f} ms")
    target.release()
    dst.release()


def start_and_stop(ctx, kept: int) -> None:
    import terrascape.render.deferred as deferred
    from terrascape.bench.viewer import flight, settle_frames
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.viewer.session import ViewerSession

    deferred.KEPT_GBUFFERS = kept
    hm = generate("diamond-square", 513, seed=1, spacing=VIEW_SPACING)
    cams = flight(hm, 24)
    fbo = ctx.simple_framebuffer(SIZE)

    class Surface:
        pass

    surface = Surface()
    surface.fbo, surface.present = fbo, ctx.finish
    session = ViewerSession(ctx, hm, size=SIZE, warn=lambda m: None, target_fps=15.0)
    session.state.technique, session.state.lod = "material", "roam"
    session.state.triangle_target = 80_000
    settle_frames(session, surface, cams[0])
    session.resolution.scale = 0.65
    plan = [cams[0]] * 3 + cams[1:6] + [cams[5]] * 3 + cams[6:10] + [cams[9]] * 3
    frames = []
    for cam in plan:
        session.camera = cam
        t0 = time.perf_counter()
        session.render(fbo, 0.0)  # dt 0: the scale stays where it was set
        ctx.finish()
        frames.append(f"{session.drawn_scale:.0%} {(time.perf_counter() - t0) * 1e3:.0f}")
    print(f"geometry buffers kept: {kept}; frames (size, ms): " + ", ".join(frames))
    session.release()
    fbo.release()
    deferred.KEPT_GBUFFERS = 2


def main() -> None:
    from terrascape.render.context import create_headless_context

    ctx = create_headless_context()
    enlargement(ctx)
    for kept in (2, 1, 2, 1):
        start_and_stop(ctx, kept)


if __name__ == "__main__":
    main()
