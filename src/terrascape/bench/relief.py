"""Relief texturing quality and speed (Janković 2010 §2.3–2.4, §2.7).

Tables:

1. **Quality per technique × view angle × field**: every technique renders its hit UV into an
   RGBA32F framebuffer (``relief/quad.glsl`` with ``u_output = 1``) which is compared pixel by
   pixel with the exact CPU reference (:mod:`terrascape.relief.reference`): mean / p95 UV
   error in texels, % pixels off by > 1 texel, % pixels that skipped a feature (hit deeper
   than the reference by > 0.01 of the depth range), texture fetches per pixel (counted in
   the shader), ms per frame and the time ratio to relief 16+8. Pre-warped relief texture
   mapping (CPU) is in the same table, timed on the CPU.
2. **Self-shadowing** vs the exact shadow, and its cost.
3. **Janković 2010 §2.7 reproduction**: texture vs parallax vs relief mapping on the terrain mesh
   (TerrainRenderer, planar-mapped relief texture) for the thesis's three textures.

Headless llvmpipe is a CPU rasteriser: absolute ms are not GPU figures; ratios are what
compare with the thesis's FPS tables.
"""

from __future__ import annotations

import time

import numpy as np

from terrascape.bench import BenchTable, best_of
from terrascape.camera import Camera, frame_terrain

ANGLES = (30, 60, 70, 80)
# The thesis's relief mapping: 16 equal linear steps, 8 binary steps — the time baseline.
RELIEF_16_8 = {"march": "fixed", "linear_steps": 16, "binary_steps": 8}
TECHNIQUES: list[tuple[str, str, dict]] = [
    # (label, shader technique, settings)
    ("parallax", "parallax", {}),
    ("offset limiting", "offset_limiting", {}),
    ("steep parallax 16", "steep", {"linear_steps": 16}),
    ("POM 16", "pom", {"linear_steps": 16}),
    ("relief 16+8", "relief", RELIEF_16_8),
    # ReliefSettings() for "relief": the default mode (see ReliefSettings: march)
    ("relief default: clearance steps Δs = gap/(1 + 0.025·L), 1.5 texels..1/16 "
     "(1/32 on a field with walls), + 4 binary",
     "relief", {}),
    ("relief adaptive (1 texel, 16..256)+8", "relief",
     {"march": "angle", "step_texels": 1.0, "max_steps": 256, "binary_steps": 8}),
    # the grazing-angle setting: steps follow the ray's length, three texels each
    ("relief adaptive (3 texels, 16..96)+8", "relief",
     {"march": "angle", "step_texels": 3.0, "max_steps": 96, "binary_steps": 8}),
    ("interval 16+8", "interval", {"linear_steps": 16, "binary_steps": 8}),
    ("cone step 32+8", "cone", {"cone_steps": 32, "binary_steps": 8}),
    ("min/max exact", "minmax", {}),
]


def _camera(theta: float, aspect: float = 1.0):
    return Camera.orbit((0, 0, 0), 30.0, 90.0 - theta, 2.0, aspect=aspect, fov_y=40)


def _quad(tex_size: int, fb: int, depth: float):
    from terrascape.relief.reference import ReliefQuad

    # About one texel per pixel at the view centre: pixel footprint 2·tan(20°)·2/fb world.
    texel_world = 2.0 * np.tan(np.radians(20.0)) * 2.0 / fb
    tiles = round(8.0 / (texel_world * tex_size), 2)
    return ReliefQuad((-4, 0, -4), (8, 0, 0), (0, 0, 8), depth, (tiles, tiles))


def _fields(tex: int):
    from terrascape.relief.fields import city_field, natural_field

    return {"city": city_field(tex, seed=0), "natural": natural_field(tex, seed=0)}


def _metrics(out, ref, tex):
    v = ref.valid
    err = np.hypot(*(out[..., :2] - ref.uv).transpose(2, 0, 1))[v] * tex
    deeper = (out[..., 2] - ref.depth)[v] > 0.01
    return {
        "mean": float(err.mean()),
        "p95": float(np.percentile(err, 95)),
        "off1": float((err > 1.0).mean() * 100),
        "skip": float(deeper.mean() * 100),
        "fetch": float(out[..., 3][v].mean()),
    }


class RoundTimes:
    """Wall and process-CPU ms of every job in every round of :func:`_time_interleaved`."""

    def __init__(self, keys) -> None:
        self.wall: dict = {k: [] for k in keys}
        self.cpu: dict = {k: [] for k in keys}

    def best_wall(self, key) -> float:
        return min(self.wall[key])

    def best_cpu(self, key) -> float:
        return min(self.cpu[key])

    def ratio(self, key, base) -> float:
        """Median over rounds of CPU(key) / CPU(base), both from the same round.

        The host's speed drifts by tens of % over seconds (other guests on the shared
        cores); two jobs timed back to back see nearly the same speed, so their ratio in one
        round is stable where each one's best time over the rounds is not (bests from
        different rounds mix different speeds)."""
        return float(np.median(np.asarray(self.cpu[key]) / np.asarray(self.cpu[base])))

    def extra(self, key, without, base) -> float:
        """Median over rounds of (CPU(key) − CPU(without)) / CPU(base): the cost that
        ``key`` adds to ``without``, in units of ``base``, all from the same round."""
        k, w, b = (np.asarray(self.cpu[x]) for x in (key, without, base))
        return float(np.median((k - w) / b))


def _time_interleaved(jobs: dict, rounds: int = 5, prepare: dict | None = None) -> RoundTimes:
    """Wall and process-CPU ms of each job in each of ``rounds`` interleaved rounds (after
    one warm-up call each). Interleaving puts every job of a cell in the same stretch of
    time, and the order alternates (forward, backward) so a drift in host speed during a
    round does not always favour the same jobs; CPU time (both llvmpipe threads) depends
    much less than wall time on how many of the 2 shared cores other work leaves free.
    ``prepare[key]``, if given, runs untimed before each timed call of ``jobs[key]``."""
    for job in jobs.values():
        job()
    times = RoundTimes(jobs)
    keys = list(jobs)
    for r in range(rounds):
        for key in keys if r % 2 == 0 else keys[::-1]:
            if prepare is not None:
                prepare[key]()
            w0, c0 = time.perf_counter(), time.process_time()
            jobs[key]()
            w1, c1 = time.perf_counter(), time.process_time()
            times.wall[key].append((w1 - w0) * 1000.0)
            times.cpu[key].append((c1 - c0) * 1000.0)
    return times


def _prewarp_row(heights, quad, cam, fb, tex):
    from terrascape.relief.prewarp import prewarp, prewarp_coefficients, sample_bilinear
    from terrascape.relief.reference import ReliefQuad, quad_entry, reference_image

    # Pre-warping works on one untiled tile: measure it on a quad showing one texture copy.
    single = ReliefQuad((-0.5, 0, -0.5), (1, 0, 0), (0, 0, 1), quad.depth)
    cam1 = _camera_from(cam, scale=1.0 / 8.0 * quad.uv_scale[0])
    centres = (np.arange(tex) + 0.5) / tex
    ident = np.stack(np.meshgrid(centres, centres), -1)
    coeffs = prewarp_coefficients(single, cam1.eye)
    disp = 1.0 - heights
    times = _time_interleaved({"pw": lambda: prewarp(ident, disp, coeffs)})
    warped, _ = prewarp(ident, disp, coeffs)
    uv0, _, valid = quad_entry(single, cam1, fb, fb)
    img = sample_bilinear(warped, uv0)
    ref = reference_image(heights, single, cam1, fb, fb)
    v = ref.valid & valid & np.isfinite(img).all(-1)
    d = np.abs(img - np.mod(ref.uv, 1.0))
    err = np.hypot(*np.minimum(d, 1 - d).transpose(2, 0, 1))[v] * tex
    return {"mean": float(err.mean()), "p95": float(np.percentile(err, 95)),
            "off1": float((err > 1).mean() * 100), "ms": times.best_wall("pw"),
            "cpu": times.best_cpu("pw")}


def _camera_from(cam, scale):
    eye = cam.eye * scale
    return Camera.look_at(eye, (0, 0, 0), aspect=cam.aspect, fov_y=cam.fov_y,
                          near=cam.near * scale, far=cam.far)


def quality_tables(ctx, *, tex=256, fb=512, depth=0.1, angles=ANGLES, quick=False, rounds=5):
    from terrascape.relief.reference import reference_image
    from terrascape.render.relief_quad import ReliefQuadRenderer, ReliefSettings

    quad = _quad(tex, fb, depth)
    cols = ["field", "angle°", "technique", "mean err (texel)", "p95 err (texel)",
            "% > 1 texel", "% skipped feature", "fetches/px", "ms/frame", "CPU ms/frame",
            "× relief 16+8"]
    quality = BenchTable(
        f"Relief quality vs exact reference ({tex}² texture, depth {depth} UV, {fb}² "
        "framebuffer)", cols)
    shadow = BenchTable(
        "Self-shadowing vs exact shadow (light azimuth 60°, elevation 35°)",
        ["field", "angle°", "technique", "% pixels disagree", "ms with shadow",
         "CPU ms with shadow", "shadow cost (× relief 16+8 time)"])
    from terrascape.lighting.sun import sun_direction

    light = sun_direction(60.0, 35.0)

    def job(rr, c, tech, st, output="hit"):
        def frame():
            rr.draw(quad, c, tech, settings=st, output=output, light_dir=light)
            ctx.finish()
        return frame

    for fname, heights in _fields(tex).items():
        r = ReliefQuadRenderer(ctx, heights, size=(fb, fb), depth_hint=depth)
        try:
            for theta in angles:
                cam = _camera(theta)
                ref = reference_image(heights, quad, cam, fb, fb, light_dir=light)
                rows, jobs, shadow_rows = [], {}, []
                for label, tech, kw in TECHNIQUES:
                    st = ReliefSettings(**kw)
                    out = r.render(quad, cam, tech, settings=st)
                    m = _metrics(out, ref, tex)
                    rows.append([fname, theta, label, m["mean"], m["p95"], m["off1"],
                                 m["skip"], m["fetch"]])
                    jobs[label] = job(r, cam, tech, st)
                    if tech in ("relief", "minmax") and not kw:
                        sst = st.with_(shadows=True)
                        sh = r.render(quad, cam, tech, settings=sst, output="shadow",
                                      light_dir=light)
                        dis = ((sh[..., 0] > 0.5) != ref.shadow)[ref.valid].mean() * 100
                        shadow_rows.append([fname, theta, label, float(dis)])
                        jobs[("shadow", label)] = job(r, cam, tech, sst, "shadow")
                times = _time_interleaved(jobs, rounds=rounds)
                base = "relief 16+8"
                for row in rows:
                    label = row[2]
                    quality.rows.append([*row, times.best_wall(label), times.best_cpu(label),
                                         times.ratio(label, base)])
                for row in shadow_rows:
                    key = ("shadow", row[2])
                    shadow.rows.append([*row, times.best_wall(key), times.best_cpu(key),
                                        times.extra(key, row[2], base)])
                pw = _prewarp_row(heights, quad, cam, min(fb, 256), tex)
                quality.rows.append([fname, theta, "pre-warp (CPU, one tile)", pw["mean"],
                                     pw["p95"], pw["off1"], "", "", pw["ms"], pw["cpu"],
                                     pw["cpu"] / times.best_cpu(base)])
        finally:
            r.release()
    quality.notes += [
        "angle = view direction from the quad normal at the screen centre; one texel ≈ one "
        "pixel there; tiled quad; errors over every pixel that sees the quad",
        "% skipped feature: hit deeper than the exact first hit by > 0.01 of the depth range",
        "relief default: ReliefSettings(); the longest clearance step is 1/32 of the ray "
        "on the city (it has walls: neighbouring texels ≥ 0.25 of the depth range apart, "
        "terrascape.relief.fields.has_walls), 1/16 on the natural field",
        "fetches/px: texture fetches counted in the shader (min/max: one texelFetch per "
        "visited node; a level-0 node fetches its cell's 4 corner depths as one RGBA texel)",
        "pre-warp: one untiled tile seen from the same direction; UV error of the texel "
        "the pre-warped + bilinear texture shows (linear reconstruction blends UVs across "
        "occlusion edges); ms = CPU pre-warp of the tile",
        f"llvmpipe timings (CPU rasteriser, 2 shared cores): {rounds} interleaved rounds "
        "after a warm-up, every technique of a cell in each round, order reversed every "
        "other round; ms/frame = best wall time, CPU ms = best process CPU time (both "
        "llvmpipe threads); × relief 16+8 = median over the rounds of the CPU time ratio "
        "within a round (the host's speed drifts between rounds, much less within one)",
    ]
    shadow.notes += [
        "relief (default mode): from the surface point at the hit's uv toward the light in "
        "steps of one texel of the light ray, at most 16; min/max: exact hierarchical march "
        "toward the light",
        "both are measured at their own view hit: where the view ray missed a thin wall, the "
        "shadow of the wrong point is compared with the exact one",
        "shadow cost = median over the rounds of (CPU time with shadow − without) / relief "
        "16+8 CPU time, all three from the same round",
        "the relief default's view march is 1/32 of the ray per step at most on the city "
        "(a field with walls), 1/16 on the natural field (ReliefSettings)",
    ]
    if quick:
        quality.notes.append("--quick: small sizes, one angle")
    return [quality, shadow]


def prewarp_table(*, tex=512, angles=ANGLES):
    """CPU time of the two-pass pre-warp of a ``tex``² relief texture (RGB + target)."""
    from terrascape.relief.fields import city_field
    from terrascape.relief.prewarp import prewarp, prewarp_coefficients
    from terrascape.relief.reference import ReliefQuad

    heights = city_field(tex, seed=0)
    colour = np.random.default_rng(0).random((tex, tex, 3))
    quad = ReliefQuad((-0.5, 0, -0.5), (1, 0, 0), (0, 0, 1), 0.1)
    table = BenchTable(f"Pre-warped relief texture mapping: CPU pre-warp of a {tex}² "
                       "city relief texture (RGB)",
                       ["angle°", "ms/frame", "k3", "covered %"])
    for theta in angles:
        cam = _camera(theta)
        co = prewarp_coefficients(quad, cam.eye * 0.8)
        ms = best_of(lambda c=co: prewarp(colour, 1.0 - heights, c), repeat=3, warmup=1)
        _, covered = prewarp(colour, 1.0 - heights, co)
        table.rows.append([theta, ms * 1000.0, co.k3, float(covered.mean() * 100)])
    table.notes.append("numba, two 1-D passes in occlusion-compatible order, 2 shared cores")
    return table


def cone_map_table(*, sizes=(256, 512, 1024)):
    """Build time of the cone technique's cone map (:func:`footprint_cone_map`) on the
    natural and city fields: best of 3 after a warm-up, numba's threads."""
    import numba

    from terrascape.relief.cone_map import footprint_cone_map

    table = BenchTable("Cone step mapping: building the cone map (CPU, once per texture)",
                       ["field", "texels", "s", "ns/texel", "median cone ratio"])
    for tex in sizes:
        for name, heights in _fields(tex).items():
            cones = footprint_cone_map(heights)  # also the timing's warm-up
            seconds = best_of(lambda h=heights: footprint_cone_map(h), repeat=3, warmup=0)
            table.rows.append([name, f"{tex}²", seconds, seconds / tex**2 * 1e9,
                               float(np.median(cones[..., 1]))])
    table.notes.append(f"exact cones searched by blocks of texels, {numba.get_num_threads()} "
                       "numba threads; the cone technique builds one when its texture is "
                       "first drawn")
    return table


# Janković 2010 §2.7 (test configuration 2): FPS of texture mapping vs parallax / relief.
SEED_FPS = {
    "urban 512² tiled": {"texture": 176, "relief": 44, "parallax_tex": 894, "parallax": 867},
    "urban 1024² stretched": {"texture": 196, "relief": 56, "parallax_tex": 885,
                              "parallax": 807},
    "natural 1280²": {"texture": 170, "relief": 60, "parallax_tex": 893, "parallax": 808},
}


def _terrain_pixels(img_a, img_b, mask):
    """Mean, p99 and % of terrain pixels over 4 levels of the largest RGB difference."""
    d = np.abs(img_a.astype(np.int16) - img_b.astype(np.int16))[..., :3].max(axis=-1)[mask]
    if d.size == 0:
        return [float("nan")] * 3
    return [float(d.mean()), float(np.percentile(d, 99)), float((d > 4).mean() * 100.0)]


def seed_table(ctx, *, size=(1280, 720), terrain=257, quick=False):
    """Janković 2010 §2.7 on the terrain mesh: texture mapping vs parallax vs relief mapping for
    the thesis's three textures, whole terrain in view, with the image error of each row
    against relief 16+8 and the height fetches per pixel."""
    from terrascape.generate import diamond_square
    from terrascape.render.relief_techniques import RELIEF_DEFAULTS, relief_variant
    from terrascape.render.terrain import TerrainRenderer

    hm = diamond_square(terrain, seed=1, roughness=0.5)
    renderer = TerrainRenderer(ctx, hm)
    fbo = ctx.framebuffer([ctx.texture(size, 4)], ctx.depth_renderbuffer(size))
    lo, hi = hm.min, hm.max
    cam = frame_terrain(hm.extent, (lo, hi), azimuth=210.0, elevation=35.0,
                        aspect=size[0] / size[1])
    cases = [
        ("urban 512² tiled", "city", 512 if not quick else 128, 16.0),
        ("urban 1024² stretched", "city", 1024 if not quick else 128, 1.0),
        ("natural 1280²", "natural", 1280 if not quick else 128, 1.0),
    ]
    d = RELIEF_DEFAULTS
    lod = {k: d[k] for k in ("lod_step", "lod_precision", "lod_secant", "lod_clearance",
                             "lod_min_span", "lod_nearest_from")}
    lod_label = (f"LOD relief ({d['lod_step']:g}-texel steps, {d['lod_precision']:g} px"
                 + (" + secant" if d["lod_secant"] else "")
                 + f", nearest mip from level {d['lod_nearest_from']:g})"
                 + (" = default relief" if d["relief_lod"] else ""))
    # (label, technique, its extra #defines, parameters). "texture mapping" is the row every
    # drop is measured against: the relief program with TECHNIQUE_PLAIN, i.e. the same
    # relief texture (normal + height tint), colour texture and Phong constants at the
    # undisplaced coordinate.
    rows = [
        ("texture mapping", "relief", {"TECHNIQUE": 0}, {}),
        ("texture mapping (region colour only)", "plain", {}, {}),
        ("parallax", "parallax", {}, {"relief_lod": d["relief_lod"], **lod}),
        ("relief 16+8", "relief", {}, {"relief_lod": False}),
        (lod_label, "relief", {}, {"relief_lod": True, **lod}),
        ("LOD relief, trilinear march throughout", "relief", {},
         {"relief_lod": True, **lod, "lod_nearest_from": -1.0}),
    ]
    table = BenchTable(
        f"Janković 2010 §2.7 reproduction on the terrain mesh ({terrain}² diamond-square, "
        f"{size[0]}×{size[1]}, whole terrain in view)",
        ["texture", "technique", "ms/frame", "CPU ms/frame", "× texture frame rate",
         "% drop vs texture", "% drop vs region colour", "seed % drop (config 2)",
         "height fetches/px", "err vs 16+8 mean", "err p99", "% px > 4 levels"])
    rounds = 3 if quick else 15
    try:
        for label, field, tex, uv_scale in cases:
            shared = {"uv_scale": uv_scale, "ks": d["ks"]}
            relief = {"relief_field": field, "relief_size": tex, "depth": 0.05,
                      "self_shadow": False}
            jobs = [(name, relief_variant(tech, name, **defs) if defs else tech, defs,
                     {**shared, **({} if tech == "plain" else relief), **extra}, tech)
                    for name, tech, defs, extra in rows]

            def frame(t, p):
                renderer.render(fbo, cam, t, p)
                ctx.finish()

            # Each timed frame follows an untimed one of the same row (its textures and
            # program bound, its caches warm): _time_interleaved's rounds of such pairs.
            calls = {name: (lambda t=tech, p=p: frame(t, p)) for name, tech, _, p, _ in jobs}
            pairs = {name: (lambda c=c: (c(), c())) for name, c in calls.items()}
            times = _time_interleaved(pairs, rounds=rounds, prepare=calls)
            images, fetches, mask = {}, {}, None
            for name, tech, defs, p, base_name in jobs:
                frame(tech, p)
                images[name] = np.frombuffer(fbo.read(components=4), np.uint8).reshape(
                    size[1], size[0], 4)
                if base_name == "plain":
                    continue
                frame(relief_variant(base_name, **defs, TERRAIN_OUTPUT_FETCHES=1),
                      {**p, "sky": False})
                out = np.frombuffer(fbo.read(components=4), np.uint8).reshape(
                    size[1], size[0], 4)
                mask = out[..., 2] == 255  # the same geometry in every row
                fetches[name] = float(out[..., 0][mask].mean())
            s = SEED_FPS[label]
            seed_drop = {"texture mapping": 0.0,
                         "parallax": (1 - s["parallax"] / s["parallax_tex"]) * 100,
                         "relief 16+8": (1 - s["relief"] / s["texture"]) * 100}
            # Ratios from CPU time within a round (RoundTimes.ratio): the rounds differ in
            # how fast the shared host runs, two rows timed back to back much less.
            base, region = "texture mapping", "texture mapping (region colour only)"
            ref = images["relief 16+8"]
            for name, *_ in jobs:
                # FPS drop = 1 − t_texture / t_technique.
                speed = times.ratio(base, name)
                table.rows.append([
                    label, name, times.best_wall(name) / 2.0, times.best_cpu(name) / 2.0,
                    speed, (1.0 - speed) * 100.0, (1.0 - times.ratio(region, name)) * 100.0,
                    seed_drop.get(name, "-"), fetches.get(name, 0.0),
                    *_terrain_pixels(images[name], ref, mask)])
    finally:
        fbo.release()
        renderer.release()
    table.notes += [
        "drop = 1 − FPS_technique / FPS_texture = 1 − t_texture / t_technique, as the thesis's "
        "tables (its averages: parallax 14.06 %, relief 69.75 %), with t the process CPU "
        f"time of a frame (both llvmpipe threads); {rounds} interleaved rounds, each row's "
        "two timed frames after an untimed one of its own, order reversed every other round; "
        "× texture frame rate = median over the rounds of t_texture / t_technique within a "
        "round (the shared host's speed drifts between rounds, much less between two rows "
        "timed back to back); ms/frame and CPU ms = best of the rounds; on an idle machine "
        "both threads run and the ratios are those of the frame rates",
        "'texture mapping' (the baseline) maps the row's relief texture without displacement: "
        "the relief program with the same textures (normal + height tint, region colour), "
        "normal-mapped Phong with the same constants (ks = "
        f"{d['ks']:g}); 'region colour only' is the plain technique (vertex-normal Phong, "
        "same ks), which samples none of the row's texture — the baseline of earlier "
        "reports, kept for comparison",
        "on the terrain mesh (TerrainRenderer, planar-mapped 16-bit normal+height texture, "
        "relief depth 0.05 UV, no self-shadowing)",
        "LOD relief: linear steps of lod_step texels of the sampled mip level along the ray "
        "(≤ 16), binary steps until the bracket is below lod_precision pixels (≤ 8), then "
        "the hit where the chord between the bracket's samples crosses the surface (secant, "
        "as POM interpolates; relief 16+8 takes the bracket's middle), one "
        "parallax step where the whole ray spans < lod_min_span px, the full 16+8 where "
        "the texture is magnified (Tatarchuk 2006: POM sample count and fallback by mip "
        "level); from mip level lod_nearest_from on the march reads the nearest mip level "
        "instead of the trilinear blend (one bilinear fetch instead of two); the shading "
        "fetch at the hit stays trilinear. Parallax with LOD skips the height fetch only "
        "where its whole shift is below lod_min_span px (nowhere in these views)",
        "error: largest RGB difference to the relief 16+8 image over terrain pixels, in "
        "8-bit levels; height fetches per terrain pixel counted in the shader "
        "(TERRAIN_OUTPUT_FETCHES), the shading fetches at the hit not included",
        "llvmpipe renders on the CPU: fragment cost dominates far more than on a GPU",
    ]
    if quick:
        table.notes.append("--quick: 128² relief textures, small framebuffer")
    return [table]


# Precision × field-family table: the techniques a user picks between, each field family at
# several seeds (natural also at several roughness exponents); every row the worst seed.
PRECISION_TECHNIQUES: list[tuple[str, str, dict]] = [
    ("relief default", "relief", {}),
    ("relief 16+8", "relief", RELIEF_16_8),
    ("relief grazing (3 texels, 16..96)+8", "relief",
     {"march": "angle", "step_texels": 3.0, "max_steps": 96, "binary_steps": 8}),
    ("cone step 32+8", "cone", {"cone_steps": 32, "binary_steps": 8}),
    ("min/max exact", "minmax", {}),
]
PRECISION_ANGLES = (30, 70, 80)
BITS = (8, 16, 32)


def field_families(tex: int, seeds=(0, 1, 2)) -> dict[str, list]:
    """Each family's fields: natural at three roughness exponents × seeds, city, fences."""
    from terrascape.relief.fields import city_field, fence_field, natural_field

    return {
        "natural β 2.6/3.2/4.0": [natural_field(tex, seed=s, beta=b)
                                  for b in (2.6, 3.2, 4.0) for s in seeds],
        "city": [city_field(tex, seed=s, block=min(32, tex // 4), street=4) for s in seeds],
        "fences (1 texel)": [fence_field(tex, seed=s, fences=max(4, tex // 8)) for s in seeds],
    }


def precision_table(ctx, *, tex=256, fb=384, depth=0.1, angles=PRECISION_ANGLES,
                    seeds=(0, 1, 2), bits=BITS) -> BenchTable:
    """Quality of each technique against the exact hit of the surface the texture samples
    (8-bit, 16-bit or float heights), worst over every field of a family."""
    from terrascape.relief.reference import reference_image
    from terrascape.render.relief_quad import ReliefQuadRenderer, ReliefSettings

    quad = _quad(tex, fb, depth)
    table = BenchTable(
        f"Relief quality by texture precision and field family ({tex}² textures, {fb}² "
        "framebuffer; each figure the worst field of its family)",
        ["heights", "family", "angle°", "technique", "p95 err (texel)", "% > 1 texel",
         "% skipped feature"])
    for family, fields in field_families(tex, seeds).items():
        worst: dict = {}
        for heights in fields:
            for b in bits:
                r = ReliefQuadRenderer(ctx, heights, size=(fb, fb), bits=b, depth_hint=depth)
                try:
                    for theta in angles:
                        cam = _camera(theta)
                        # the exact hit of the surface as sampled (r.heights: quantised)
                        ref = reference_image(r.heights, quad, cam, fb, fb)
                        for label, tech, kw in PRECISION_TECHNIQUES:
                            out = r.render(quad, cam, tech, settings=ReliefSettings(**kw))
                            m = _metrics(out, ref, tex)
                            key = (b, theta, label)
                            old = worst.get(key, (0.0, 0.0, 0.0))
                            worst[key] = (max(old[0], m["p95"]), max(old[1], m["off1"]),
                                          max(old[2], m["skip"]))
                finally:
                    r.release()
        for (b, theta, label), (p95, off1, skip) in worst.items():
            name = {8: "8-bit", 16: "16-bit", 32: "float"}[b]
            table.rows.append([name, family, theta, label, p95, off1, skip])
    table.rows.sort(key=lambda row: (row[1], BITS.index({"8-bit": 8, "16-bit": 16,
                                                         "float": 32}[row[0]]), row[2]))
    table.notes += [
        f"seeds {list(seeds)}; natural fields at spectral exponents 2.6, 3.2 and 4.0 (rougher "
        "to smoother); city of blocks with 1–2 texel courtyard walls; one-texel fences",
        "8/16-bit: the packed normal + height texture (codes of the stretched heights); the "
        "reference, the min/max pyramid and the cone map are all built from the sampled "
        "codes (terrascape.relief.fields.sampled_heights)",
        "min/max exact: target p95 ≤ 0.01 texel at every precision",
    ]
    return table


def run(quick: bool = False) -> list[BenchTable]:
    from terrascape.render.context import headless_context

    t0 = time.perf_counter()
    # released on the way out, the caller's own GL context made current again
    with headless_context() as ctx:
        if quick:
            tables = quality_tables(ctx, tex=64, fb=128, angles=(60,), quick=True)
            tables.append(precision_table(ctx, tex=64, fb=128, angles=(70,), seeds=(0, 1)))
            tables.append(prewarp_table(tex=128, angles=(60,)))
            tables.append(cone_map_table(sizes=(64, 128)))
            tables += seed_table(ctx, size=(320, 240), terrain=65, quick=True)
        else:
            tables = quality_tables(ctx)
            tables.append(precision_table(ctx))
            tables.append(prewarp_table())
            tables.append(cone_map_table())
            tables += seed_table(ctx)
    tables[-1].notes.append(f"benchmark wall time {time.perf_counter() - t0:.1f} s")
    return tables


__all__ = ["run"]
