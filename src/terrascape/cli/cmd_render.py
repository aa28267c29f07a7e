"""``terrascape render``: headless OpenGL rendering of a heightmap to PNG, a PNG sequence or
an MP4 turntable (thin layer over :mod:`terrascape.render.offscreen`)."""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np
import typer

from terrascape.cli.app import app, out, progress, timed
from terrascape.cli.app import console as err
from terrascape.cli.parsing import parse_floats, parse_size
from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError

GENERATORS = ("diamond-square", "fault", "hills")


def _load(heightmap: Path | None, generate: str | None, gen_size: int, seed: int):
    if (heightmap is None) == (generate is None):
        raise InvalidParameterError(
            "give either a HEIGHTMAP file or --generate diamond-square|fault|hills (not both)"
        )
    if generate is not None:
        from terrascape import generate as gen

        if generate == "diamond-square":
            return gen.diamond_square(gen_size, seed=seed)
        if generate == "fault":
            return gen.fault_formation(gen_size, seed=seed)
        if generate == "hills":
            return gen.hills(gen_size, seed=seed)
        raise InvalidParameterError(
            f"--generate must be one of {', '.join(GENERATORS)}, got {generate!r}"
        )
    from terrascape.io import read_heightmap

    try:
        return read_heightmap(heightmap)
    except TerrascapeError:
        raise
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"cannot read heightmap {heightmap}: {exc}") from exc


def _clip_planes(hm, exaggeration: float, eye: np.ndarray) -> tuple[float, float]:
    """Near/far that contain the whole terrain box seen from ``eye``."""
    ex, ez = hm.extent
    lo, hi = hm.min * exaggeration, hm.max * exaggeration
    corners = np.array([[x, y, z] for x in (0, ex) for y in (lo, hi) for z in (0, ez)])
    far = float(np.linalg.norm(corners - eye, axis=1).max()) * 1.1 + 1.0
    return max(far * 1e-4, 1e-3), far


def build_camera(hm, size, exaggeration, camera: str | None, target: str | None, orbit: str | None):
    """The CLI's camera: ``--camera/--target``, ``--orbit`` around the centre, or the
    default framing of the whole terrain (``None``)."""
    from terrascape.camera import Camera

    aspect = size[0] / size[1]
    if orbit is not None and (camera is not None or target is not None):
        raise InvalidParameterError("use either --orbit or --camera/--target, not both")
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
        eye = np.array(parse_floats(camera, 3, name="--camera X,Y,Z"))
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


@app.command("render")
def render_command(
    heightmap: Path = typer.Argument(
        None,
        help="Heightmap file (any format `terrascape info` reads); omit with --generate.",
        show_default=False,
    ),
    output: Path = typer.Option(
        None,
        "--output",
        "-o",
        help="Output file: .png (one frame / PNG sequence base name) or .mp4. "
        "[default: render.png, or turntable.mp4 with --format mp4]",
        show_default=False,
    ),
    size: str = typer.Option("1280x720", "--size", help="Image size WIDTHxHEIGHT in pixels."),
    technique: str = typer.Option(
        "plain",
        "--technique",
        "-t",
        help="Shading technique: plain, regions, texture3d, splat, bump (+ registered ones).",
    ),
    camera: str = typer.Option(
        None,
        "--camera",
        help="Camera position X,Y,Z in world units (with --target).",
        show_default=False,
    ),
    target: str = typer.Option(
        None,
        "--target",
        help="Point the camera looks at, X,Y,Z in world units.",
        show_default=False,
    ),
    orbit: str = typer.Option(
        None,
        "--orbit",
        help="Camera on an orbit around the terrain centre: AZ,EL,DIST (degrees, degrees, "
        "world units). Default: a view that frames the whole terrain.",
        show_default=False,
    ),
    sun: str = typer.Option(
        "135,45", "--sun", help="Sun azimuth,elevation in degrees (azimuth clockwise from north)."
    ),
    exaggeration: float = typer.Option(
        1.0, "--exaggeration", help="Vertical exaggeration factor (heights × F)."
    ),
    lighting: str = typer.Option(
        "daylight", "--lighting",
        help="Lighting: daylight (sun + sky light, soft terrain shadows per pixel, analytic "
        "sky, haze, filmic tone map), vertex (Phong, no shadows), lightmap (the seed's "
        "lightmap with shadows), none.",
    ),
    sea_level: float = typer.Option(
        None, "--sea-level",
        help="Draw water up to this height (heightmap units, before --exaggeration). "
        "[default: no water]",
        show_default=False,
    ),
    water_depth: Path = typer.Option(
        None, "--water-depth",
        help="Lakes: a .npy float32 water-depth map of the heightmap's shape (e.g. from "
        "erosion), drawn as water where > 0.",
        show_default=False,
    ),
    surround: str = typer.Option(
        None, "--surround",
        help="Beyond the terrain's edge: sea (water to the horizon), plane (ground at the "
        "lowest height, the edge's colour) or fade (haze). [default: sea with --sea-level, "
        "else plane]",
        show_default=False,
    ),
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
    haze: float = typer.Option(
        None, "--haze",
        help="Daylight: aerial-perspective extinction per world unit (0 = off). "
        "[default: automatic from the terrain size]",
        show_default=False,
    ),
    wireframe: bool = typer.Option(False, "--wireframe", help="Overlay the triangle edges."),
    turntable: int = typer.Option(
        0,
        "--turntable",
        help="Render N frames orbiting the terrain (0 = a single image).",
    ),
    fmt: str = typer.Option(
        "png", "--format", help="Turntable output: png (numbered sequence) or mp4."
    ),
    fps: float = typer.Option(30.0, "--fps", help="MP4 frames per second."),
    generate: str = typer.Option(
        None,
        "--generate",
        help="Generate the terrain instead of reading a file: diamond-square, fault or hills.",
        show_default=False,
    ),
    gen_size: int = typer.Option(
        257,
        "--gen-size",
        help="Side in samples of the generated terrain (2**n + 1 for diamond-square).",
    ),
    seed: int = typer.Option(0, "--seed", help="Seed of the generator and built-in materials."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines or progress bar."),
) -> None:
    """Render a heightmap with OpenGL (headless EGL) to a PNG, a PNG sequence or an MP4."""
    from terrascape.io.atomic import atomic_output, check_output_path
    from terrascape.render.context import headless_context
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.render.offscreen import turntable as run_turntable
    from terrascape.render.techniques import get_technique

    wh = parse_size(size, name="--size")
    sun_az, sun_el = parse_floats(sun, 2, name="--sun AZ,EL")
    if not math.isfinite(exaggeration) or exaggeration <= 0:
        raise InvalidParameterError(f"--exaggeration must be > 0, got {exaggeration}")
    if turntable < 0:
        raise InvalidParameterError(f"--turntable must be >= 0, got {turntable}")
    if fmt not in ("png", "mp4"):
        raise InvalidParameterError(f"--format must be png or mp4, got {fmt!r}")
    get_technique(technique)  # fail fast on a typo, listing the techniques
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
        output = Path("turntable.mp4" if turntable and fmt == "mp4" else "render.png")
    want = ".mp4" if turntable and fmt == "mp4" else ".png"
    if output.suffix.lower() != want:
        raise InvalidParameterError(f"output must end in {want} here, got {output.name!r}")
    if not turntable:
        check_output_path(output, force=force)
    params = {"lighting": lighting, "wireframe": wireframe, "seed": seed,
              "sea_level": sea_level, "surround": surround, "turbidity": turbidity,
              "exposure": exposure, "haze": haze}

    with timed("load", quiet=quiet):
        hm = _load(heightmap, generate, gen_size, seed)
    if water_depth is not None:
        params["water_depth"] = _load_water_depth(water_depth, hm)
    from terrascape.render.atmosphere import sea_level_note

    note = sea_level_note(hm, sea_level)
    if note:
        err.print(f"[yellow]warning:[/yellow] {note}")
    with contextlib.ExitStack() as stack:
        with timed("GL context", quiet=quiet):
            ctx = stack.enter_context(headless_context())
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
                )
            out.print(
                f"{files[0]}"
                if len(files) == 1
                else f"{files[0]} … {files[-1]} ({len(files)} frames)"
            )
            return
        cam = build_camera(hm, wh, exaggeration, camera, target, orbit)
        renderer = OffscreenRenderer(ctx, hm, size=wh, exaggeration=exaggeration,
                                     quality=quality)
        try:
            with timed(f"render ({technique})", quiet=quiet):
                img = renderer.render(cam, technique, {**params, "sun": (sun_az, sun_el)})
        finally:
            renderer.release()
        from PIL import Image

        with atomic_output(output, force=force) as tmp:
            Image.fromarray(img[..., :3]).save(tmp, format="PNG")
        out.print(str(output))
