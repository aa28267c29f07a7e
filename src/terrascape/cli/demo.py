"""The demo (README command one): generate terrains with each generator, texture and shade
them, render them headless with every texturing technique, and write everything to a folder.

Each stage is a plain function over the public API, so the demo doubles as an end-to-end
smoke run of the library. Stages needing OpenGL report a clear reason when no context can
be made instead of failing the generation/texturing stages.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from terrascape.camera import Camera
from terrascape.errors import GLUnavailableError, InvalidParameterError, TerrascapeError
from terrascape.heightmap import Heightmap


@dataclass
class DemoResult:
    """What the demo wrote: (path, description, seconds) rows, plus skipped stages."""

    written: list[tuple[Path, str, float]] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def add(self, path: Path, what: str, seconds: float) -> None:
        self.written.append((path, what, seconds))


def _save_png(array: np.ndarray, path: Path, *, force: bool) -> None:
    from PIL import Image

    from terrascape.io.atomic import atomic_output

    with atomic_output(path, force=force) as tmp:
        Image.fromarray(array).save(tmp, format="PNG")


def generate_stage(
    out: Path, result: DemoResult, *, size: int, force: bool
) -> dict[str, Heightmap]:
    """One heightmap per generator: 16-bit PNG (world units restorable) + 8-bit preview."""
    from terrascape.filters import hydraulic_erosion, thermal_erosion
    from terrascape.generate import diamond_square, fault_formation, fbm, hills, ridged
    from terrascape.io import write_heightmap, write_preview

    makers: dict[str, Callable[[int], Heightmap]] = {
        "diamond_square": lambda n: diamond_square(n, roughness=0.55, seed=7, spacing=2.0)
        .normalised(0, 180),
        "fault": lambda n: fault_formation(n, iterations=400, falloff="cosine", width=24.0,
                                           seed=7, spacing=2.0).normalised(0, 180),
        "hills": lambda n: hills(n, count=300, seed=7, spacing=2.0).normalised(0, 180),
        "fbm": lambda n: fbm(n, scale=n / 3, octaves=8, seed=7, spacing=2.0)
        .normalised(0, 180),
        "ridged": lambda n: ridged(n, scale=n / 3, octaves=8, seed=7, spacing=2.0)
        .normalised(0, 180),
        "eroded": lambda n: hydraulic_erosion(
            thermal_erosion(diamond_square(n, roughness=0.55, seed=7, spacing=2.0)
                            .normalised(0, 180), iterations=20),
            droplets=20_000, seed=7),
    }
    maps: dict[str, Heightmap] = {}
    for name, make in makers.items():
        make(17)  # numba compiles (or loads its cache) here, not inside the timed call
        t0 = time.perf_counter()
        hm = make(size)
        seconds = time.perf_counter() - t0
        maps[name] = hm
        path16 = out / f"{name}_heightmap.png"
        write_heightmap(hm, path16, force=force)
        result.add(path16, f"{name} heightmap, 16-bit PNG {hm.cols}×{hm.rows}", seconds)
        preview = out / f"{name}_preview.png"
        write_preview(hm, preview, force=force)
        result.add(preview, f"{name} preview, 8-bit PNG", 0.0)
        raw = out / f"{name}_heightmap.r16"
        write_heightmap(hm, raw, force=force)
        result.add(raw, f"{name} heightmap, RAW 16-bit", 0.0)
    return maps


def texture_stage(out: Path, result: DemoResult, hm: Heightmap, *, force: bool) -> None:
    """Region texture × shadowed lightmap (a textured, shaded top-down image), normal map,
    splat maps."""
    from terrascape.lighting import lightmap, pack_normal_height
    from terrascape.texture import (
        material_ids_from_rules,
        pack_splat_maps,
        region_texture,
        splat_weights,
    )

    small = hm.with_heights(hm.heights[:33, :33])  # numba compile/cache load, untimed
    region_texture(small, scale=2, jitter=0.05, seed=7,
                   lightmap=lightmap(small, 135.0, 25.0, ambient=0.25, shadows=True))
    pack_normal_height(small, bits=8)
    pack_splat_maps(splat_weights(material_ids_from_rules(small)))
    t0 = time.perf_counter()
    light = lightmap(hm, 135.0, 25.0, ambient=0.25, shadows=True)
    t_light = time.perf_counter() - t0
    _save_png((light * 255).astype(np.uint8), out / "lightmap.png", force=force)
    result.add(out / "lightmap.png", "lightmap with ray-cast shadows (sun 135°/25°)", t_light)

    t0 = time.perf_counter()
    tex = region_texture(hm, scale=2, jitter=0.05, seed=7, lightmap=light)
    seconds = time.perf_counter() - t0
    _save_png(tex, out / "textured_topdown.png", force=force)
    result.add(out / "textured_topdown.png", "region texture × lightmap, top-down", seconds)

    t0 = time.perf_counter()
    packed = pack_normal_height(hm, bits=8)
    seconds = time.perf_counter() - t0
    _save_png(packed, out / "normal_height.png", force=force)
    result.add(out / "normal_height.png", "normal map (RGB) + height (A)", seconds)

    t0 = time.perf_counter()
    images = pack_splat_maps(splat_weights(material_ids_from_rules(hm)))
    seconds = time.perf_counter() - t0
    for i, img in enumerate(images):
        _save_png(img, out / f"splat_{i}.png", force=force)
        result.add(out / f"splat_{i}.png", f"splat alpha maps, layers {4 * i}–{4 * i + 3}",
                   seconds if i == 0 else 0.0)


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
    from terrascape.render.context import create_headless_context, describe_context
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.render.techniques import technique_names

    try:
        ctx = create_headless_context()
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
        ctx.release()


def lod_stage(out: Path, result: DemoResult, hm: Heightmap, renderer, camera, *,
              size: tuple[int, int], force: bool) -> None:
    """ROAM (80,000-triangle target, seed 001 §5.3) and geomipmapping (2 px tolerance) meshes
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
    hero = maps["diamond_square"]
    if "texture" in stages:
        texture_stage(output, result, hero, force=force)
    if "render" in stages:
        try:
            render_stage(output, result, hero, size=render_size, force=force)
        except TerrascapeError as exc:
            result.skipped.append(f"rendering: {exc}")
    return result
