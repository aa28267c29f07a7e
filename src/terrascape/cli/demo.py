"""The demo (README command one): generate terrains with each generator, texture and shade
them, render them headless with every texturing technique, and write everything to a folder.

Each stage is a plain function over the public API, so the demo doubles as an end-to-end
smoke run of the library. Stages needing OpenGL report a clear reason when no context can
be made instead of failing the generation/texturing stages.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from terrascape.camera import Camera
from terrascape.errors import GLUnavailableError, InvalidParameterError, TerrascapeError
from terrascape.heightmap import Heightmap
from terrascape.objects import load_objects


@dataclass
class DemoResult:
    """What the demo wrote: (path, description, seconds) rows, plus skipped stages."""

    written: list[tuple[Path, str, float]] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    masks: dict[str, np.ndarray] = field(default_factory=dict)

    def add(self, path: Path, what: str, seconds: float) -> None:
        self.written.append((path, what, seconds))


def _save_png(array: np.ndarray, path: Path, *, force: bool) -> None:
    from PIL import Image

    from terrascape.io.atomic import atomic_output

    with atomic_output(path, force=force) as tmp:
        Image.fromarray(array).save(tmp, format="PNG")


def hero_terrain(size: int) -> tuple[Heightmap, dict[str, np.ndarray]]:
    """The showcase terrain: the default diamond-square (4 m grid, relief 20 % of its
    extent) eroded by the default river-erosion model, with its masks."""
    from terrascape.filters import erode
    from terrascape.generate.registry import generate

    raw = generate("diamond-square", size, seed=7, spacing=4.0)
    result = erode(raw)
    return result.heightmap, result.masks


def generate_stage(
    out: Path, result: DemoResult, *, size: int, force: bool
) -> dict[str, Heightmap]:
    """One heightmap per registered generator plus the eroded showcase terrain: 16-bit PNG
    (world units restorable), RAW16 and an 8-bit preview; the erosion masks as .npy."""
    from terrascape.generate.registry import generate, generator_names
    from terrascape.io.atomic import atomic_output

    makers: dict[str, Callable[[int], Heightmap]] = {
        name.replace("-", "_"): (lambda n, name=name: generate(name, n, seed=7, spacing=2.0))
        for name in generator_names()
    }
    maps: dict[str, Heightmap] = {}
    for name, make in makers.items():
        make(17)  # numba compiles (or loads its cache) here, not inside the timed call
        t0 = time.perf_counter()
        hm = make(size)
        maps[name] = hm
        _write_heightmap_files(out, result, name, hm, time.perf_counter() - t0, force=force)
    hero_terrain(17)  # compile, untimed
    t0 = time.perf_counter()
    eroded, masks = hero_terrain(size)
    maps["eroded"] = eroded
    _write_heightmap_files(out, result, "eroded", eroded, time.perf_counter() - t0,
                           force=force, what="diamond-square + river erosion (stream power)")
    for mask_name, mask in masks.items():
        path = out / f"eroded_{mask_name}.npy"
        with atomic_output(path, force=force) as tmp, open(tmp, "wb") as fh:
            np.save(fh, mask)
        result.add(path, f"erosion mask: {mask_name} (float32)", 0.0)
    result.masks = masks
    return maps


def _write_heightmap_files(out: Path, result: DemoResult, name: str, hm: Heightmap,
                           seconds: float, *, force: bool, what: str | None = None) -> None:
    from terrascape.io import write_heightmap, write_preview

    path16 = out / f"{name}_heightmap.png"
    write_heightmap(hm, path16, force=force)
    result.add(path16, f"{what or name} heightmap, 16-bit PNG {hm.cols}×{hm.rows}", seconds)
    preview = out / f"{name}_preview.png"
    write_preview(hm, preview, force=force)
    result.add(preview, f"{name} preview, 8-bit PNG", 0.0)
    raw = out / f"{name}_heightmap.r16"
    write_heightmap(hm, raw, force=force)
    result.add(raw, f"{name} heightmap, RAW 16-bit", 0.0)


def texture_stage(out: Path, result: DemoResult, hm: Heightmap, *, force: bool,
                  masks: dict[str, np.ndarray] | None = None) -> None:
    """Daylight lightmap (sun, sky light and soft shadows, tone-mapped), the terrain's
    default material × that light as a top-down map, the packed normal + height texture,
    and splat maps (3 layers per RGB image) with a colour preview."""
    from terrascape.cli.cmd_texture import layer_colour, splat_preview, splat_rgb_images
    from terrascape.lighting import lightmap, pack_normal_height
    from terrascape.texture import (
        default_regions,
        material_ids_from_rules,
        pack_splat_maps,
        splat_weights,
    )
    from terrascape.texture.terrain_material import material_texture

    small = hm.with_heights(hm.heights[:33, :33])  # numba compile/cache load, untimed
    material_texture(small, lightmap=lightmap(small, 135.0, 25.0))
    pack_normal_height(small, bits=8)
    pack_splat_maps(splat_weights(material_ids_from_rules(small)))
    t0 = time.perf_counter()
    light = lightmap(hm, 135.0, 25.0)
    t_light = time.perf_counter() - t0
    _save_png(np.rint(light * 255).astype(np.uint8), out / "lightmap.png", force=force)
    result.add(out / "lightmap.png", "daylight lightmap: sun, sky light, soft shadows "
               "(sun 135°/25°)", t_light)

    t0 = time.perf_counter()
    tex = material_texture(hm, masks=masks, scale=2, seed=7, lightmap=light)
    seconds = time.perf_counter() - t0
    _save_png(tex, out / "textured_topdown.png", force=force)
    result.add(out / "textured_topdown.png", "terrain material × daylight, top-down", seconds)

    t0 = time.perf_counter()
    packed = pack_normal_height(hm, bits=8)
    seconds = time.perf_counter() - t0
    _save_png(packed, out / "normal_height.png", force=force)
    result.add(out / "normal_height.png", "normal map (RGB) + height (A)", seconds)

    t0 = time.perf_counter()
    regions = default_regions(hm)
    weights = splat_weights(material_ids_from_rules(hm), len(regions))
    images = splat_rgb_images(pack_splat_maps(weights), len(regions))
    preview = splat_preview(weights, [layer_colour(k, r.name) for k, r in enumerate(regions)])
    seconds = time.perf_counter() - t0
    for i, img in enumerate(images):
        names = ", ".join(r.name for r in regions[3 * i:3 * i + 3])
        _save_png(img, out / f"splat_{i}.png", force=force)
        result.add(out / f"splat_{i}.png", f"splat weights (R, G, B = {names})",
                   seconds if i == 0 else 0.0)
    _save_png(preview, out / "splat_preview.png", force=force)
    result.add(out / "splat_preview.png", "splat layers blended in their colours", 0.0)


def _shore_camera(hm: Heightmap, sea_level: float, aspect: float) -> Camera:
    """A low camera looking along a coast: at the land sample nearest the map centre that is
    a little above the sea, from the sea side, 45 m up and a fifth of the map away (closer,
    the heightmap's 4 m samples show as smeared facets)."""
    h = hm.heights
    rows, cols = hm.shape
    span = float(h.max() - h.min())
    near_shore = (h > sea_level + 0.01 * span) & (h < sea_level + 0.06 * span)
    if not near_shore.any():
        return _close_up_camera(hm, aspect)
    rr, cc = np.nonzero(near_shore)
    k = int(np.argmin((rr - rows / 2) ** 2 + (cc - cols / 2) ** 2))
    r, c = int(rr[k]), int(cc[k])
    dx, dz = hm.spacing
    # towards the lower neighbourhood (the sea), a fifth of the map's extent away
    win = h[max(0, r - 8):r + 9, max(0, c - 8):c + 9]
    lr, lc = np.unravel_index(int(np.argmin(win)), win.shape)
    vz, vx = (lr + max(0, r - 8) - r) * dz, (lc + max(0, c - 8) - c) * dx
    norm = float(np.hypot(vx, vz)) or 1.0
    reach = 0.2 * max(hm.extent)
    target = (c * dx, float(h[r, c]), r * dz)
    eye = (target[0] + vx / norm * reach, sea_level + 45.0, target[2] + vz / norm * reach)
    extent = max(hm.extent)
    return Camera.look_at(eye, (target[0], float(h[r, c]) + 5.0, target[2]), aspect=aspect,
                          near=0.5, far=4.0 * extent)


DUSK_TIME = "2026-06-21T20:15"  # the showcase's time of day (local solar time)
DUSK_LATITUDE = 45.8


def showcase_stage(out: Path, result: DemoResult, hm: Heightmap, masks: dict[str, np.ndarray],
                   *, size: tuple[int, int], force: bool) -> None:
    """The beauty renders: the eroded terrain at golden hour (landscape view), a low coast
    with water and shadows at midday, a top-down map, the coast with trees, rocks and
    houses, and the terrain at dusk under the sky of that moment — high quality (2×2
    samples)."""
    from terrascape.lighting.sky_time import resolve_place, sky_for
    from terrascape.render.context import headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    # headless_context: releasing it makes a caller's own GL context current again
    gl = contextlib.ExitStack()
    try:
        ctx = gl.enter_context(headless_context())
    except GLUnavailableError as exc:
        result.skipped.append(f"showcase renders: {exc}")
        return
    sea = float(np.percentile(hm.heights, 12))
    material = {name: masks[name] for name in ("flow", "deposition", "wear") if name in masks}
    renderer = OffscreenRenderer(ctx, hm, size=size, quality="high")
    try:
        views = (
            ("showcase_golden_hour.png", "eroded terrain at golden hour (sun 250°/8°)",
             renderer.default_camera(), (250.0, 8.0)),
            ("showcase_coast.png", "low view of the coast: water, soft shadows (sun 150°/35°)",
             _shore_camera(hm, sea, size[0] / size[1]), (150.0, 35.0)),
            ("showcase_map.png", "top-down map (sun 135°/40°)",
             renderer.default_camera(elevation=89.0, azimuth=180.0), (135.0, 40.0)),
        )
        for name, what, camera, sun in views:
            t0 = time.perf_counter()
            image = renderer.render(camera, "material",
                                    {**material, "sun": sun, "sea_level": sea})
            _save_png(image[..., :3], out / name, force=force)
            result.add(out / name, what, time.perf_counter() - t0)
        # The coast again with what stands on it: the built-in trees, bushes, rocks and
        # houses by the default rules, with the sun's cascaded shadow maps.
        t0 = time.perf_counter()
        objects = load_objects("default", hm, seed=1, masks=masks, sea_level=sea)
        renderer.terrain.set_objects(objects)
        image = renderer.render(_shore_camera(hm, sea, size[0] / size[1]), "material",
                                {**material, "sun": (150.0, 35.0), "sea_level": sea})
        _save_png(image[..., :3], out / "showcase_forest.png", force=force)
        result.add(out / "showcase_forest.png",
                   f"the coast with {len(objects):,} trees, bushes, rocks and houses and "
                   "their shadows", time.perf_counter() - t0)
        renderer.terrain.set_objects(None)
        # The sky of a moment: dusk at midsummer, the glow over the sea in the north-west.
        t0 = time.perf_counter()
        state = sky_for(DUSK_TIME, resolve_place(None, DUSK_LATITUDE, None))
        image = renderer.render(renderer.default_camera(), "material",
                                {**material, "sun": state.sun, "sky_state": state,
                                 "sea_level": sea})
        _save_png(image[..., :3], out / "showcase_dusk.png", force=force)
        result.add(out / "showcase_dusk.png",
                   f"dusk: {DUSK_TIME.replace('T', ' ')} local solar time at {DUSK_LATITUDE}° N "
                   f"(the sun {-state.sun[1]:.1f}° below the horizon)", time.perf_counter() - t0)
    finally:
        renderer.release()
        gl.close()
    result.notes.append(f"showcase: sea level {sea:.1f} m (12th percentile of the heights); "
                        "render times include the shadow and sky-light setup")


def _close_up_camera(hm: Heightmap, aspect: float):
    """A low camera over the terrain's centre, where relief texturing is visible."""
    w, d = hm.extent
    r, c = hm.rows // 2, hm.cols // 2
    ground = float(hm.heights[r, c])
    target = (c * hm.spacing[0], ground, r * hm.spacing[1])
    return Camera.orbit(target, 210.0, 22.0, 0.12 * max(w, d), aspect=aspect,
                        near=0.5, far=4.0 * max(w, d))


def _time_frames(render: Callable[[], np.ndarray], repeat: int = 3) -> tuple[np.ndarray, float]:
    """The image and the best wall time of ``repeat`` frames after one warm-up frame."""
    image = render()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        image = render()
        best = min(best, time.perf_counter() - t0)
    return image, best


def render_stage(
    out: Path, result: DemoResult, hm: Heightmap, *, size: tuple[int, int], force: bool
) -> None:
    """Render the terrain with every registered technique (headless), from an overview and a
    close-up camera, and time each frame (best of three, read-back included); then the
    view-dependent LOD meshes (ROAM, geomipmapping) as wireframe overlays."""
    # moderngl is imported only when a context is made: without the [render] extra that
    # raises GLUnavailableError (with the install hint), handled below
    from terrascape.render.context import describe_context, headless_context
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.render.techniques import technique_names

    # headless_context: releasing it makes a caller's own GL context current again
    gl = contextlib.ExitStack()
    try:
        ctx = gl.enter_context(headless_context())
    except GLUnavailableError as exc:
        result.skipped.append(f"rendering: {exc}")
        return
    info = describe_context(ctx)
    result.notes.append(f"OpenGL: {info['renderer']} ({info['version']}); render times are the "
                        f"best of three {size[0]}×{size[1]} frames including read-back")
    renderer = OffscreenRenderer(ctx, hm, size=size)
    try:
        overview = renderer.default_camera()
        close = _close_up_camera(hm, size[0] / size[1])
        for technique in technique_names():
            for view, camera in (("overview", overview), ("closeup", close)):
                image, seconds = _time_frames(lambda c=camera, t=technique: renderer.render(c, t))
                path = out / f"render_{technique}_{view}.png"
                _save_png(image[..., :3], path, force=force)
                result.add(path, f"{technique} ({view})", seconds)
        lod_stage(out, result, hm, renderer, close, size=size, force=force)
    finally:
        renderer.release()
        gl.close()


def lod_stage(out: Path, result: DemoResult, hm: Heightmap, renderer, camera, *,
              size: tuple[int, int], force: bool) -> None:
    """ROAM (80,000-triangle target, Filipović 2008 §5.3) and geomipmapping (2 px tolerance) meshes
    for the close-up view: wireframe renders plus the ROAM mesh as OBJ."""
    from terrascape.io.mesh import compact_mesh, write_mesh
    from terrascape.lod import Geomipmap, Roam

    wire = {"wireframe": True}
    small = hm.with_heights(hm.heights[:33, :33])  # numba compile/cache load, untimed
    Roam(small).update(camera, size, max_triangles=100)
    Geomipmap(small, patch_size=17).update(camera, size, tolerance_px=2.0, cull=True)
    roam = Roam(hm)
    t0 = time.perf_counter()
    roam.update(camera, size, max_triangles=80_000)
    seconds = time.perf_counter() - t0
    tris = roam.triangles()
    renderer.terrain.set_indices(tris)
    image = renderer.render(camera, "regions", wire)
    _save_png(image[..., :3], out / "lod_roam_wireframe.png", force=force)
    result.add(out / "lod_roam_wireframe.png",
               f"ROAM (target 80,000): {len(tris):,} triangles", seconds)
    vertices, faces = compact_mesh(hm, tris)
    write_mesh(out / "lod_roam.obj", vertices, faces, force=force)
    result.add(out / "lod_roam.obj", f"ROAM mesh, {len(vertices):,} vertices", 0.0)

    geo = Geomipmap(hm, patch_size=33)
    t0 = time.perf_counter()
    geo.update(camera, size, tolerance_px=2.0, cull=True)
    seconds = time.perf_counter() - t0
    tris = geo.triangles()
    renderer.terrain.set_indices(tris)
    image = renderer.render(camera, "regions", wire)
    _save_png(image[..., :3], out / "lod_geomipmap_wireframe.png", force=force)
    result.add(out / "lod_geomipmap_wireframe.png",
               f"geomipmapping (τ = 2 px): {len(tris):,} triangles", seconds)
    renderer.terrain.set_indices(None)


STAGES = ("generate", "texture", "render")


def run_demo(
    output: Path,
    *,
    size: int = 513,
    render_size: tuple[int, int] = (1280, 720),
    force: bool = False,
    stages: tuple[str, ...] = ("generate", "texture", "render"),
) -> DemoResult:
    """Run the demo stages into ``output`` (created if missing)."""
    if size < 17 or (size - 1) & (size - 2):
        raise InvalidParameterError(f"demo size must be 2**n + 1 and at least 17, got {size}")
    unknown = set(stages) - set(STAGES)
    if unknown:
        raise InvalidParameterError(
            f"unknown demo stage(s) {', '.join(sorted(unknown))}; choose from {', '.join(STAGES)}"
        )
    output = Path(output)
    output.mkdir(parents=True, exist_ok=True)
    result = DemoResult()
    maps = generate_stage(output, result, size=size, force=force)
    hero = maps["eroded"]
    if "render" in stages:
        try:
            showcase_stage(output, result, hero, result.masks, size=render_size, force=force)
        except TerrascapeError as exc:
            result.skipped.append(f"showcase renders: {exc}")
    if "texture" in stages:
        texture_stage(output, result, hero, force=force, masks=result.masks)
    if "render" in stages:
        try:
            render_stage(output, result, hero, size=render_size, force=force)
        except TerrascapeError as exc:
            result.skipped.append(f"rendering: {exc}")
    return result
