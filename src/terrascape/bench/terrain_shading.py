"""What each cut of the terrain's per-pixel shading buys in the viewer (software GL).

One process, one viewer session (ROAM holding 80,000 triangles, 1280×720, the viewer's
daylight look: shadows, sky light, haze, the ``fade`` surround) on the viewer benchmark's
camera flight; at each camera every variant draws a frame in turn, round after round, so
the ratios compare frames drawn seconds apart under the same load. The variants add the
cuts one by one:

* ``before``: every material layer sampled per pixel, trilinear layer textures, float32
  sun/sky visibility (the haze reads the frame's sky table, ``u_sky_lut``, in every row);
* ``+ 3 heaviest layers`` (``MATERIAL_TOP_LAYERS``, material only);
* ``+ nearest mip`` (material layer textures read from one mip level);
* ``+ 8-bit visibility``;
* ``+ light geometry buffer`` (material's deferred pass: float16 normals, only the world
  position and depth cleared, the tangents rebuilt from the normals, not stored);
* ``+ one mip level per pixel`` (hex-tiled lookups at one level, ``textureLod``, instead of
  a ``textureGrad`` each; two-channel detail normals) — the default.

Each row also gives the mean and largest difference of its last frame from ``before``'s
(8-bit levels), so a cut that buys time by changing the picture shows.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from dataclasses import replace

import numpy as np

from terrascape.bench import BenchTable

SIZE = (1280, 720)
ROAM_TRIANGLES = 80_000
QUICK_SIDE, FULL_SIDE = 257, 513
QUICK_FRAMES, QUICK_ROUNDS = 3, 3
# the reference paths of the last two cuts (shader defines)
_STORED = {"MATERIAL_STORED_TANGENTS": 1}
_GRAD = {"HEX_GRAD_PER_LOOKUP": 1}
# (label, shader defines, trilinear layer textures, float visibility, light geometry buffer
# and two-channel detail normals)
VARIANTS = (
    ("before", {"MATERIAL_TOP_LAYERS": 7, **_STORED, **_GRAD}, True, True, False),
    ("+ 3 heaviest layers", {**_STORED, **_GRAD}, True, True, False),
    ("+ nearest mip", {**_STORED, **_GRAD}, False, True, False),
    ("+ 8-bit visibility", {**_STORED, **_GRAD}, False, False, False),
    ("+ light geometry buffer", _GRAD, False, False, True),
    ("+ one mip level per pixel (default)", {}, False, False, True),
)
MATERIAL_ONLY = ("+ 3 heaviest layers", "+ nearest mip", "+ light geometry buffer",
                 "+ one mip level per pixel (default)")


def _session(ctx, n: int):
    from terrascape.generate.registry import VIEW_SPACING, generate
    from terrascape.viewer.session import ViewerSession

    hm = generate("diamond-square", n, seed=1, spacing=VIEW_SPACING)
    session = ViewerSession(ctx, hm, size=SIZE, hud=False, lod_time_budget_ms=None,
                            warn=lambda message: None)
    session.state.triangle_target = ROAM_TRIANGLES
    session.state.lod = "roam"
    return hm, session


def _use_variant(session, defines, trilinear, float_visibility, light):
    """Make the session's renderer draw ``variant`` (shader defines on the technique, the
    layer textures' mip filter, the visibility texture's type, the geometry buffer and the
    detail normals' channels)."""
    import moderngl

    from terrascape.render.techniques import get_technique

    r = session.renderer
    r.visibility_8bit = not float_visibility
    r._deferred.light_gbuffer = light
    if session.state.technique == "material" and _NORMALS.get(id(r)) != light:
        r.set_texture("u_normals", _detail_normals(session, two_channels=light))
        r.ctx.finish()  # the upload and its mip levels before any timed frame
        _NORMALS[id(r)] = light
    for name in ("u_layers", "u_normals"):
        if name in r._textures:
            r._textures[name][0].filter = (
                moderngl.LINEAR_MIPMAP_LINEAR if trilinear else moderngl.LINEAR_MIPMAP_NEAREST,
                moderngl.LINEAR)
    base = type(r).render

    def render(fbo, camera, technique, params=None):
        tech = get_technique(technique)
        tech = replace(tech, defines={**(tech.defines or {}), **defines})
        return base(r, fbo, camera, tech, params)

    r.render = render


_NORMALS: dict[int, bool] = {}  # renderer id -> the detail normals it holds (two channels)


def _detail_normals(session, *, two_channels: bool):
    """The material's detail normal layers of the session's frames as the renderer builds
    them (RG), or with all four channels as before (the shader reads x and y either way)."""
    from terrascape.render.tech_material import MATERIAL_TECHNIQUE, build_layer_normals
    from terrascape.render.techniques import TextureData
    from terrascape.texture.photo_materials import photo_material_layers

    p = MATERIAL_TECHNIQUE.resolve(session.frame_params("material"))
    if two_channels:
        return build_layer_normals(session.renderer.heightmap, p)
    layers = photo_material_layers(int(p["material_size"]), seed=int(p["seed"]))
    return TextureData(np.ascontiguousarray(layers.normals), kind="array", repeat=True,
                       mip_blend=False)


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.bench.viewer import flight
    from terrascape.render.context import headless_context

    n = QUICK_SIDE if quick else FULL_SIDE
    frames = QUICK_FRAMES if quick else 6
    rounds = QUICK_ROUNDS if quick else 3
    techniques = ("material", "plain")
    # released on the way out, the caller's own GL context made current again
    with headless_context() as ctx:
        fbo = ctx.simple_framebuffer(SIZE)
        renderer = ctx.info.get("GL_RENDERER", "?")
        hm, session = _session(ctx, n)
        cams = flight(hm, frames, SIZE)
        times: dict[tuple[str, str], list[float]] = {}
        last: dict[tuple[str, str], np.ndarray] = {}
        try:
            for tech in techniques:
                session.state.technique = tech
                variants = [v for v in VARIANTS
                            if tech == "material" or v[0] not in MATERIAL_ONLY]
                for _ in range(rounds):
                    # variant after variant on the same camera: paired frames under one load
                    for cam in cams:
                        session.camera = cam
                        for label, defines, trilinear, float_vis, light in variants:
                            _use_variant(session, defines, trilinear, float_vis, light)
                            session.render(fbo, 0.0)  # LOD converged, textures, program built
                            ctx.finish()
                            # again: the first frame may have made the layer textures
                            _use_variant(session, defines, trilinear, float_vis, light)
                            t0 = time.perf_counter()
                            session.render(fbo, 0.0)
                            ctx.finish()
                            times.setdefault((tech, label), []).append(time.perf_counter() - t0)
                            last[(tech, label)] = np.frombuffer(fbo.read(components=3),
                                                                np.uint8).astype(np.int16)
                    print(f"bench terrain_shading: {tech} round done", file=sys.stderr, flush=True)
        finally:
            session.release()
            fbo.release()
    table = BenchTable(
        f"Terrain shading cuts, viewer frames at {SIZE[0]}×{SIZE[1]}, ROAM "
        f"{ROAM_TRIANGLES // 1000}k, diamond-square {n}×{n} ({frames} cameras × {rounds} "
        "interleaved rounds)",
        ["technique / variant", "median ms", "frames/s", "× before", "mean diff",
         "max diff"],
    )
    for tech in techniques:
        ref = times[(tech, "before")]
        for label, *_ in VARIANTS:
            t = times.get((tech, label))
            if t is None:
                continue
            # ratio per camera and round (paired frames), then the median; three significant
            # digits, not two decimals: a `before` frame stalled on a loaded host made a
            # ratio under 0.005, which two decimals printed as 0
            ratio = statistics.median(a / b for a, b in zip(t, ref, strict=True))
            diff = np.abs(last[(tech, label)] - last[(tech, "before")])
            table.rows.append([f"{tech}: {label}", round(1000 * statistics.median(t), 1),
                               round(1.0 / statistics.median(t), 1), float(f"{ratio:.3g}"),
                               round(float(diff.mean()), 2), int(diff.max())])
    table.notes += [
        f"headless EGL, GL_RENDERER {renderer}; every frame: LOD update + sky + terrain, "
        "glFinish; frames/s from the median frame",
        "× before: median of the per-frame ratios to the same camera's `before` frame in "
        "the same round; diff: 8-bit levels between the last frames",
        f"load average at the end: {os.getloadavg()[0]:.2f} (absolute times drift on a "
        "shared machine; the ratios are what count)",
    ]
    return [table]


__all__ = ["VARIANTS", "run"]
