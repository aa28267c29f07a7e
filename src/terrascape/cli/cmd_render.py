"""``terrascape render``: headless OpenGL rendering of a heightmap to PNG, a PNG sequence or
an MP4 turntable (thin layer over :mod:`terrascape.render.offscreen`)."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np
import typer

from terrascape.camera import Camera
from terrascape.cli.app import MAX_MEMORY, app, out, progress, timed, use_max_memory
from terrascape.cli.app import console as err
from terrascape.cli.geo_options import NO_REPROJECT, metric_map
from terrascape.cli.parsing import is_world_store, parse_floats, parse_size
from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError
from terrascape.generate.registry import generator_names, names_help

#: Largest --turntable: frame files are numbered with four digits.
MAX_TURNTABLE_FRAMES = 10_000


def _load(heightmap: Path | None, generate: str | None, gen_size: int, seed: int,
          gen_param: list[str] | None = None, *, no_reproject: bool = False):
    if (heightmap is None) == (generate is None):
        raise InvalidParameterError(
            f"give either a HEIGHTMAP file or --generate {'|'.join(generator_names())} "
            "(not both)"
        )
    if generate is not None:
        from terrascape.generate.registry import VIEW_SPACING, parse_params
        from terrascape.generate.registry import generate as make

        return make(generate, gen_size, seed=seed, spacing=VIEW_SPACING,
                    **parse_params(generate, gen_param))
    from terrascape.io import read_heightmap

    try:
        hm = read_heightmap(heightmap)
    except TerrascapeError:
        raise
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"cannot read heightmap {heightmap}: {exc}") from exc
    return metric_map(hm, no_reproject=no_reproject)


def _clip_planes(hm, exaggeration: float, eye: np.ndarray) -> tuple[float, float]:
    """Near/far that contain the whole terrain box seen from ``eye``."""
    ex, ez = hm.extent
    lo, hi = hm.min * exaggeration, hm.max * exaggeration
    corners = np.array([[x, y, z] for x in (0, ex) for y in (lo, hi) for z in (0, ez)])
    far = float(np.linalg.norm(corners - eye, axis=1).max()) * 1.1 + 1.0
    return max(far * 1e-4, 1e-3), far


def ground_height(hm, x: float, z: float) -> float:
    """Bilinear terrain height at world ``(x, z)`` (clamped to the map's edges)."""
    from scipy.ndimage import map_coordinates

    col = min(max(x / hm.spacing[0], 0.0), hm.cols - 1.0)
    row = min(max(z / hm.spacing[1], 0.0), hm.rows - 1.0)
    return float(map_coordinates(hm.heights, [[row], [col]], order=1, mode="nearest")[0])


def _camera_eye(hm, exaggeration: float, camera: str, camera_height: float | None) -> np.ndarray:
    """``--camera X,Y,Z`` (or ``X,Z`` with ``--camera-height H``: H above the ground at x,z);
    a camera under the terrain is a warning naming the ground height there."""
    import warnings

    parts = camera.split(",")
    if camera_height is not None:
        if not math.isfinite(camera_height):
            raise InvalidParameterError(f"--camera-height must be finite, got {camera_height}")
        xz = parse_floats(camera, len(parts) if len(parts) in (2, 3) else 2,
                          name="--camera X,Z (with --camera-height)")
        x, z = xz[0], xz[-1]
        return np.array([x, ground_height(hm, x, z) * exaggeration + camera_height, z])
    eye = np.array(parse_floats(camera, 3, name="--camera X,Y,Z"))
    ground = ground_height(hm, eye[0], eye[2]) * exaggeration
    if eye[1] < ground:
        warnings.warn(
            f"the camera (y = {eye[1]:.6g}) is {ground - eye[1]:.6g} under the ground, whose "
            f"height at x = {eye[0]:.6g}, z = {eye[2]:.6g} is {ground:.6g}; raise Y or use "
            "--camera-height H to place the camera H above the ground",
            stacklevel=2,
        )
    return eye


def build_camera(hm, size, exaggeration, camera: str | None, target: str | None, orbit: str | None,
                 camera_height: float | None = None):
    """The CLI's camera: ``--camera/--target``, ``--orbit`` around the centre, or the
    default framing of the whole terrain (``None``)."""
    aspect = size[0] / size[1]
    if orbit is not None and (camera is not None or target is not None):
        raise InvalidParameterError("use either --orbit or --camera/--target, not both")
    if camera_height is not None and camera is None:
        raise InvalidParameterError("--camera-height needs --camera X,Z (and --target)")
    if orbit is not None:
        az, el, dist = parse_floats(orbit, 3, name="--orbit AZ,EL,DIST")
        ex, ez = hm.extent
        centre = np.array([ex / 2, (hm.min + hm.max) / 2 * exaggeration, ez / 2])
        cam = Camera.orbit(centre, az, el, dist, fov_y=45.0, aspect=aspect)
        near, far = _clip_planes(hm, exaggeration, cam.eye)
        return Camera.orbit(centre, az, el, dist, fov_y=45.0, aspect=aspect, near=near, far=far)
    if camera is not None or target is not None:
        if camera is None or target is None:
            raise InvalidParameterError("--camera and --target must be given together")
        eye = _camera_eye(hm, exaggeration, camera, camera_height)
        tgt = parse_floats(target, 3, name="--target X,Y,Z")
        near, far = _clip_planes(hm, exaggeration, eye)
        return Camera.look_at(eye, tgt, fov_y=45.0, aspect=aspect, near=near, far=far)
    return None


def _load_water_depth(path: Path, hm) -> np.ndarray:
    """A float32 water-depth map (.npy) of the heightmap's shape."""
    if path.suffix.lower() != ".npy":
        raise InvalidParameterError(f"--water-depth must be a .npy file, got {path.name!r}")
    try:
        depth = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"cannot read water depth {path}: {exc}") from exc
    if depth.shape != hm.shape or not np.issubdtype(depth.dtype, np.floating):
        raise InvalidParameterError(
            f"--water-depth must be a float array of shape {hm.shape}, got {depth.dtype} "
            f"{depth.shape}")
    if not np.isfinite(depth).all():
        raise InvalidParameterError("--water-depth contains NaN/inf")
    return depth.astype(np.float32)


def _check_time_options(time, latitude, longitude, day_cycle, frames, turntable) -> float:
    """Validate --time/--latitude/--longitude/--day-cycle/--frames before any work; returns
    the day cycle's duration in seconds (0 without one)."""
    from terrascape.lighting.sky_time import parse_duration
    from terrascape.lighting.solar_position import check_latitude, check_longitude, parse_time

    if time is None and day_cycle is None and (latitude is not None or longitude is not None):
        raise InvalidParameterError("--latitude/--longitude place the sky of --time; give "
                                    "--time (or --day-cycle)")
    if latitude is not None:
        check_latitude(latitude)
    if longitude is not None:
        check_longitude(longitude)
    if time is not None:
        parse_time(time)
    if day_cycle is None:
        return 0.0
    if turntable:
        raise InvalidParameterError("use either --turntable or --day-cycle, not both")
    if not 1 <= frames <= MAX_TURNTABLE_FRAMES:
        raise InvalidParameterError(
            f"--frames must be in [1, {MAX_TURNTABLE_FRAMES}], got {frames}")
    return parse_duration(day_cycle)


def unset_option(*flags: str, help: str):
    """An option that is ``None`` unless given: what happens without it is said in its help
    text (``[default: …]``), not shown as a default value."""
    return typer.Option(None, *flags, help=help, show_default=False)


OBJECTS_HELP = (
    "Objects on the terrain: default (the built-in trees, bushes, rocks and buildings by "
    "the default rules), a .glb/.gltf mesh (scattered like trees) or a rules file "
    "(.toml/.json). [default: none]")
OBJECT_SHADOWS_HELP = (
    "Shadows of the objects: cascades (the sun's cascaded shadow maps, objects and terrain "
    "together), volumes (stencil shadow volumes) or none. [default: cascades]")


def load_objects_option(spec: str | None, hm, *, seed: int, exaggeration: float):
    """The Instances of ``--objects SPEC`` (None without the option)."""
    if spec is None:
        return None
    from terrascape.objects import load_objects

    return load_objects(spec, hm, seed=seed, exaggeration=exaggeration)


def check_object_shadows(value: str | None) -> str | None:
    from terrascape.render.objects import OBJECT_SHADOW_MODES

    if value is not None and value not in OBJECT_SHADOW_MODES:
        raise InvalidParameterError(
            f"--object-shadows must be one of {', '.join(OBJECT_SHADOW_MODES)}, got {value!r}")
    return value


def _render_world_cmd(store: Path, output: Path, wh, technique: str, params: dict, *,
                      camera, target, orbit, camera_height, exaggeration, quality, force,
                      quiet) -> None:
    """``render world.zarr``: draw the world by tiles, each at the pyramid level its
    screen error needs, within --max-memory (:mod:`terrascape.world.chunked_lod`)."""
    from PIL import Image

    from terrascape.heightmap import Heightmap
    from terrascape.io.atomic import atomic_output
    from terrascape.render.context import headless_context
    from terrascape.world.render import render_world
    from terrascape.world.store import open_world
    from terrascape.world.window import level_shape, read_level

    group, recipe = open_world(store)
    cam = None
    if camera is not None or target is not None or orbit is not None:
        # The camera options read the terrain (extent, height range, ground under the
        # camera): the coarsest stored level stands in for the world there.
        k = int(group.attrs.get("levels", 0))
        lr, lc = level_shape(recipe.shape, k)
        step = recipe.spacing * (1 << k)
        proxy = Heightmap(read_level(group, k, 0, lr, 0, lc), (step, step))
        cam = build_camera(proxy, wh, exaggeration, camera, target, orbit, camera_height)
    with timed("render world", quiet=quiet), headless_context() as ctx:
        img, frame = render_world(store, cam, size=wh, technique=technique, params=params,
                                  exaggeration=exaggeration, quality=quality, ctx=ctx)
    if not quiet:
        err.print(f"[dim]world: {frame.summary()}[/]")
    with atomic_output(output, force=force) as tmp:
        Image.fromarray(img[..., :3]).save(tmp, format="PNG")
    out.print(str(output))


@app.command("render")
def render_command(
    heightmap: Path = typer.Argument(
        None,
        help="Heightmap file (any format `terrascape info` reads) or a world store (world.zarr: "
        "only the part in view is read, at the detail it needs); omit with --generate.",
        show_default=False,
    ),
    output: Path = unset_option(
        "--output", "-o",
        help="Output file: .png (one frame / PNG sequence base name) or .mp4. "
        "[default: render.png, or turntable.mp4 with --format mp4]"),
    size: str = typer.Option("1280x720", "--size", help="Image size WIDTHxHEIGHT in pixels."),
    technique: str = typer.Option(
        "material",
        "--technique",
        "-t",
        help="Shading technique: {techniques}.",
    ),
    camera: str = unset_option(
        "--camera", help="Camera position X,Y,Z in world units (with --target)."),
    camera_height: float = unset_option(
        "--camera-height",
        help="Place the camera this far above the ground at --camera's x,z (world units; "
        "then --camera X,Z is enough)."),
    target: str = unset_option("--target", help="Point the camera looks at, X,Y,Z in world units."),
    orbit: str = unset_option(
        "--orbit",
        help="Camera on an orbit around the terrain centre: AZ,EL,DIST (degrees, degrees, "
        "world units). Default: a view that frames the whole terrain."),
    sun: str = unset_option(
        "--sun",
        help="Sun azimuth,elevation in degrees (azimuth clockwise from north). "
        "[default: 135,45]"),
    time: str = unset_option(
        "--time",
        help="Date and time, e.g. 2026-06-21T18:30: the sun, sky, moon and stars of that "
        "moment (instead of --sun). Without a UTC offset it is local solar time (12:00 = the "
        "sun due south); with one (2026-06-21T18:30+02:00) civil time, which needs "
        "--longitude or a georeferenced map. With --day-cycle: the start "
        "[default 2026-06-21T00:00]."),
    latitude: float = unset_option(
        "--latitude",
        help="Latitude in degrees north (-90..90) for --time. [default: the map's "
        "georeference, else 45]"),
    longitude: float = unset_option(
        "--longitude",
        help="Longitude in degrees east for --time (needed for a time with a UTC offset). "
        "[default: the map's georeference]"),
    day_cycle: str = unset_option(
        "--day-cycle",
        help="Render an MP4 of this much time passing from --time (e.g. 24h, 90m, 2d), "
        "the camera fixed."),
    frames: int = typer.Option(
        48, "--frames", help="Frames of the --day-cycle video."
    ),
    exaggeration: float = typer.Option(
        1.0, "--exaggeration", help="Vertical exaggeration factor (heights × F)."
    ),
    lighting: str = typer.Option(
        "daylight", "--lighting",
        help="Lighting: daylight (sun + sky light, soft terrain shadows per pixel, analytic "
        "sky, haze, filmic tone map), vertex (Phong, no shadows), lightmap (the thesis's "
        "lightmap with shadows), none.",
    ),
    sea_level: float = unset_option(
        "--sea-level",
        help="Draw water up to this height (heightmap units, before --exaggeration). "
        "[default: no water]"),
    water_depth: Path = unset_option(
        "--water-depth",
        help="Lakes: a .npy float32 water-depth map of the heightmap's shape (e.g. from "
        "erosion), drawn as water where > 0."),
    surround: str = unset_option(
        "--surround",
        help="Beyond the terrain's edge: sea (water to the horizon), plane (ground at the "
        "lowest height, made of the terrain's lowest ground material) or fade (haze). "
        "[default: sea with --sea-level, else fade]"),
    quality: str = typer.Option(
        "default", "--quality",
        help="default, or high: 2×2 supersampling and 16 shadow sweeps (seconds a frame).",
    ),
    turbidity: float = typer.Option(
        3.0, "--turbidity", help="Daylight: haze of the sky, 1.7 (very clear) to 10 (hazy)."
    ),
    exposure: float = typer.Option(
        0.0, "--exposure", help="Daylight: exposure correction in stops (EV)."
    ),
    haze: float = unset_option(
        "--haze",
        help="Daylight: aerial-perspective extinction per world unit (0 = off). "
        "[default: automatic from the terrain size]"),
    wireframe: bool = typer.Option(False, "--wireframe", help="Overlay the triangle edges."),
    objects: str = unset_option("--objects", help=OBJECTS_HELP),
    object_shadows: str = unset_option("--object-shadows", help=OBJECT_SHADOWS_HELP),
    turntable: int = typer.Option(
        0,
        "--turntable",
        help="Render N frames orbiting the terrain (0 = a single image).",
    ),
    fmt: str = typer.Option(
        "png", "--format", help="Turntable output: png (numbered sequence) or mp4."
    ),
    fps: float = typer.Option(30.0, "--fps", help="MP4 frames per second."),
    generate: str = unset_option(
        "--generate",
        help=f"Generate the terrain instead of reading a file: {names_help()} (2 m grid, "
        "relief 20 % of the extent)."),
    gen_param: list[str] = unset_option(
        "--gen-param",
        help="A generator parameter NAME=VALUE, repeatable (e.g. octaves=8); the names are "
        "the options of `terrascape generate NAME`."),
    gen_size: int = typer.Option(
        257,
        "--gen-size",
        help="Side in samples of the generated terrain (2**n + 1 for diamond-square).",
    ),
    seed: int = typer.Option(0, "--seed", help="Seed of the generator and built-in materials."),
    no_reproject: bool = NO_REPROJECT,
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines or progress bar."),
    max_memory: str = MAX_MEMORY,
) -> None:
    """Render a heightmap with OpenGL (headless EGL) to a PNG, a PNG sequence or an MP4."""
    from terrascape.io.atomic import atomic_output, check_output_path
    from terrascape.render.context import headless_context
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.render.offscreen import turntable as run_turntable
    from terrascape.render.techniques import get_technique

    wh = parse_size(size, name="--size")
    if sun is not None and (time is not None or day_cycle is not None):
        raise InvalidParameterError("give either --sun or --time/--day-cycle, not both")
    sun_az, sun_el = parse_floats(sun or "135,45", 2, name="--sun AZ,EL")
    cycle_seconds = _check_time_options(time, latitude, longitude, day_cycle, frames,
                                        turntable)
    if not math.isfinite(exaggeration) or exaggeration <= 0:
        raise InvalidParameterError(f"--exaggeration must be > 0, got {exaggeration}")
    if not 0 <= turntable <= MAX_TURNTABLE_FRAMES:
        # Frames are numbered NAME_0000.png … NAME_9999.png: more would stop sorting by name.
        raise InvalidParameterError(
            f"--turntable must be in [0, {MAX_TURNTABLE_FRAMES}] frames, got {turntable}"
        )
    if fmt not in ("png", "mp4"):
        raise InvalidParameterError(f"--format must be png or mp4, got {fmt!r}")
    technique = get_technique(technique).name  # fail fast on a typo; old names → new
    from terrascape.render.offscreen import QUALITIES
    from terrascape.render.techniques import LIGHTING_MODES

    if lighting not in LIGHTING_MODES:
        raise InvalidParameterError(
            f"--lighting must be one of {', '.join(LIGHTING_MODES)}, got {lighting!r}")
    if quality not in QUALITIES:
        raise InvalidParameterError(f"--quality must be default or high, got {quality!r}")
    if surround is not None and surround not in ("sea", "plane", "fade"):
        raise InvalidParameterError(f"--surround must be sea, plane or fade, got {surround!r}")
    if sea_level is not None and not math.isfinite(sea_level):
        raise InvalidParameterError(f"--sea-level must be finite, got {sea_level}")
    if output is None:
        output = Path("day.mp4" if day_cycle else
                      "turntable.mp4" if turntable and fmt == "mp4" else "render.png")
    want = ".mp4" if (turntable and fmt == "mp4") or day_cycle else ".png"
    if output.suffix.lower() != want:
        raise InvalidParameterError(f"output must end in {want} here, got {output.name!r}")
    if not turntable:
        check_output_path(output, force=force)
    params = {"lighting": lighting, "wireframe": wireframe, "seed": seed,
              "sea_level": sea_level, "surround": surround, "turbidity": turbidity,
              "exposure": exposure, "haze": haze,
              "object_shadows": check_object_shadows(object_shadows)}
    if object_shadows is not None and objects is None:
        raise InvalidParameterError("--object-shadows needs --objects")

    use_max_memory(max_memory)
    if heightmap is not None and generate is None and is_world_store(heightmap):
        if turntable or water_depth is not None:
            raise InvalidParameterError(
                "a world renders one frame without --water-depth: drop --turntable/--water-depth")
        _render_world_cmd(heightmap, output, wh, technique,
                          {**params, "sun": (sun_az, sun_el)}, camera=camera, target=target,
                          orbit=orbit, camera_height=camera_height, exaggeration=exaggeration,
                          quality=quality, force=force, quiet=quiet)
        return
    if generate is not None:
        from terrascape.memory import PEAK_BYTES_PER_SAMPLE, check_grid, estimate_peak

        gen_name = generate if generate in PEAK_BYTES_PER_SAMPLE else "fbm"
        check_grid("render", gen_size, gen_size, extra=estimate_peak(gen_name, gen_size, gen_size),
                   hint="use a smaller --gen-size (or raise --max-memory)")
    with timed("load", quiet=quiet):
        hm = _load(heightmap, generate, gen_size, seed, gen_param, no_reproject=no_reproject)
    if generate is None:
        from terrascape.memory import check_grid

        check_grid("render", hm.rows, hm.cols, hint="render a smaller map (or raise --max-memory)")
    if water_depth is not None:
        params["water_depth"] = _load_water_depth(water_depth, hm)
    if objects is not None:
        with timed("objects", quiet=quiet):
            instances = load_objects_option(objects, hm, seed=seed, exaggeration=exaggeration)
    else:
        instances = None
    from terrascape.render.atmosphere import sea_level_note

    note = sea_level_note(hm, sea_level)
    if note:
        err.print(f"[yellow]warning:[/yellow] {note}")
    place = None
    if time is not None or day_cycle is not None:
        from terrascape.lighting.sky_time import resolve_place

        place = resolve_place(hm, latitude, longitude)
        if place.source == "default" and not quiet:
            err.print(f"note: no --latitude and no georeference: the sky of {place.latitude:g}° "
                      "north")
    if time is not None and day_cycle is None:
        from terrascape.lighting.sky_time import sky_for

        state = sky_for(time, place)
        sun_az, sun_el = state.sun
        params["sky_state"] = state
        if not quiet:
            err.print(f"sun: azimuth {sun_az:.1f}°, elevation {sun_el:.1f}°; moon: azimuth "
                      f"{state.moon_azimuth:.1f}°, elevation {state.moon_elevation:.1f}°, "
                      f"{state.moon_illumination:.0%} lit")
    with contextlib.ExitStack() as stack:
        with timed("GL context", quiet=quiet):
            ctx = stack.enter_context(headless_context())
        if day_cycle is not None:
            from terrascape.lighting.sky_time import DEFAULT_CYCLE_START
            from terrascape.lighting.sky_time import day_cycle as cycle
            from terrascape.render.day_cycle import write_day_cycle

            states = cycle(time or DEFAULT_CYCLE_START, cycle_seconds, frames, place)
            cam = build_camera(hm, wh, exaggeration, camera, target, orbit, camera_height)
            with progress(quiet=quiet) as bar, timed("day cycle", quiet=quiet):
                task = bar.add_task("rendering", total=len(states))
                path = write_day_cycle(
                    hm, states, output, ctx=ctx, camera=cam, technique=technique, size=wh,
                    exaggeration=exaggeration, fps=fps, params=params, force=force,
                    quality=quality,
                    progress=lambda done, total: bar.update(task, completed=done))
            out.print(f"{path} ({len(states)} frames)")
            return
        if turntable:
            if camera or target or orbit:
                raise InvalidParameterError(
                    "--turntable picks its own cameras; drop --camera/--target/--orbit"
                )
            with progress(quiet=quiet) as bar, timed("turntable", quiet=quiet):
                task = bar.add_task("rendering", total=turntable)
                files = run_turntable(
                    hm,
                    turntable,
                    output,
                    fmt=fmt,
                    technique=technique,
                    size=wh,
                    sun=(sun_az, sun_el),
                    exaggeration=exaggeration,
                    fps=fps,
                    ctx=ctx,
                    params=params,
                    force=force,
                    progress=lambda done, total: bar.update(task, completed=done),
                    quality=quality,
                    objects=instances,
                )
            out.print(
                f"{files[0]}"
                if len(files) == 1
                else f"{files[0]} … {files[-1]} ({len(files)} frames)"
            )
            return
        cam = build_camera(hm, wh, exaggeration, camera, target, orbit, camera_height)
        renderer = OffscreenRenderer(ctx, hm, size=wh, exaggeration=exaggeration,
                                     quality=quality)
        try:
            renderer.terrain.set_objects(instances)
            with timed(f"render ({technique})", quiet=quiet):
                img = renderer.render(cam, technique, {**params, "sun": (sun_az, sun_el)})
        finally:
            renderer.release()
        from PIL import Image

        with atomic_output(output, force=force) as tmp:
            Image.fromarray(img[..., :3]).save(tmp, format="PNG")
        out.print(str(output))
