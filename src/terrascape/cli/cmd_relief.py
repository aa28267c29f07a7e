"""``terrascape relief`` — render a relief-textured quad with one technique to a PNG."""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape._validate import check_range
from terrascape.camera import Camera
from terrascape.cli.app import app, console, timed
from terrascape.errors import InvalidParameterError

# {relief_techniques} is filled from the technique registry when help is shown (cli/app.py).
TECHNIQUE_HELP = (
    "Technique: auto (the exact min/max tracer where the texture allows it, else relief), "
    "{relief_techniques} (on the GPU), or prewarp (relief texture mapping on the CPU, "
    "Oliveira 2000)."
)


def _shade_heights(heights, depth: float, light) -> np.ndarray:  # noqa: F821
    """Grey Lambert colour of the relief texture (for the CPU pre-warp path)."""
    import numpy as np

    from terrascape.render.relief_quad import relief_texture_data

    data = relief_texture_data(heights, depth=depth, bits=32)
    n = data[..., :3] * 2.0 - 1.0
    # Tangent frame of the default quad: +u = +X, +v = +Z, normal +Y.
    lam = np.clip(n[..., 0] * light[0] + n[..., 1] * light[2] + n[..., 2] * light[1], 0, 1)
    grey = 0.25 + 0.75 * lam
    return np.repeat(grey[..., None], 3, axis=-1) * (0.5 + 0.5 * data[..., 3:4])


@app.command("relief")
def relief_command(
    output: Path = typer.Argument(..., help="Output PNG path."),
    technique: str = typer.Option("auto", "--technique", "-t", help=TECHNIQUE_HELP),
    field: str = typer.Option("city", "--field",
                              help="Relief test field: city, natural or fences."),
    bits: int = typer.Option(32, "--bits",
                             help="Height texture precision: 8, 16 (packed) or 32 (float)."),
    texture_size: int = typer.Option(256, "--texture-size",
                                     help="Relief texture size in texels (power of two)."),
    angle: float = typer.Option(60.0, "--angle",
                                help="View angle from the quad normal, degrees [0, 85]."),
    depth: float = typer.Option(0.1, "--depth", help="Relief depth in UV units (> 0)."),
    size: str = typer.Option("512x512", "--size", help="Image size WxH in pixels."),
    linear_steps: int | None = typer.Option(
        None, "--linear-steps",
        help="Linear search steps (default 16; 32 for relief's clearance march on a field "
             "with walls, e.g. the city)."),
    binary_steps: int = typer.Option(8, "--binary-steps",
                                     help="Binary (relief) / secant (interval) steps."),
    adaptive: bool = typer.Option(False, "--adaptive/--fixed",
                                  help="Linear steps follow the view angle (1 per texel)."),
    shadows: bool = typer.Option(True, "--shadows/--no-shadows",
                                 help="Self-shadowing: the relief casts shadows on itself."),
    sun: str = typer.Option(
        "60,35", "--sun",
        help="Sun direction AZ,EL in degrees: azimuth clockwise from north (90 = east), "
             "elevation above the horizon in (0, 90]."),
    seed: int = typer.Option(0, "--seed", help="Seed of the test field."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines on stderr."),
) -> None:
    """Render one relief-mapped quad (tiled 4×4) seen at ANGLE and write it as a PNG."""
    import numpy as np
    from PIL import Image

    from terrascape.cli.parsing import parse_floats, parse_size
    from terrascape.io.atomic import atomic_output, check_output_path
    from terrascape.lighting.sun import sun_direction
    from terrascape.relief.fields import city_field, fence_field, natural_field
    from terrascape.relief.reference import ReliefQuad

    if output.suffix.lower() != ".png":
        raise InvalidParameterError(
            f"relief writes PNG images: the output must end in .png, got {output.name!r}"
        )
    check_output_path(output, force=force)
    quad_name = technique
    if technique not in ("prewarp", "auto"):
        from terrascape.render.relief_techniques import quad_technique

        quad_name = quad_technique(technique)  # registered names and their old spellings
    w, h = parse_size(size)
    check_range(angle, "angle (degrees)", 0.0, 85.0)
    az, el = parse_floats(sun, 2, name="--sun AZ,EL")
    light = sun_direction(az, el)
    makers = {"city": city_field, "natural": natural_field, "fences": fence_field}
    if field not in makers:
        raise InvalidParameterError(
            f"--field must be one of {', '.join(makers)}, got {field!r}")
    if bits not in (8, 16, 32):
        raise InvalidParameterError(f"--bits must be 8, 16 or 32, got {bits}")
    maker = makers[field]
    with timed("field", quiet=quiet):
        heights = maker(texture_size, seed=seed)
    cam = Camera.orbit((0, 0, 0), 30.0, 90.0 - angle, 2.0, aspect=w / h, fov_y=40.0)
    if technique == "prewarp":
        from terrascape.relief.prewarp import relief_texture_image

        quad = ReliefQuad.centred(size=1.0, depth=depth)
        cam = Camera.orbit((0, 0, 0), 30.0, 90.0 - angle, 1.6, aspect=w / h, fov_y=40.0)
        with timed("pre-warp + texture mapping (CPU)", quiet=quiet):
            colour = _shade_heights(heights, depth, light)
            img = relief_texture_image(colour, 1.0 - heights, quad, cam, w, h)
        rgba = np.concatenate([np.nan_to_num(img, nan=0.0),
                               np.isfinite(img[..., :1]).astype(float)], axis=-1)
    else:
        from terrascape.render.context import headless_context
        from terrascape.render.relief_quad import ReliefQuadRenderer, ReliefSettings

        quad = ReliefQuad((-2, 0, -2), (4, 0, 0), (0, 0, 4), depth, (4.0, 4.0))
        march = {"march": "angle"} if adaptive else {}  # --fixed: the default march
        settings = ReliefSettings(linear_steps=linear_steps, binary_steps=binary_steps,
                                  step_texels=1.0, shadows=shadows, **march)
        with headless_context() as ctx:
            r = ReliefQuadRenderer(ctx, heights, size=(w, h), depth_hint=depth, bits=bits)
            wanted = r.auto_technique if quad_name == "auto" else quad_name
            with timed(f"render {wanted}", quiet=quiet):
                rgba = r.render(quad, cam, wanted, settings=settings, output="colour",
                                light_dir=light)
            if r.drawn_technique != wanted:
                console.print(f"[yellow]fell back to {r.drawn_technique}[/]")
            technique = r.drawn_technique
            r.release()
    image = (np.clip(rgba[::-1], 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    with atomic_output(output, force=force) as tmp:
        Image.fromarray(image, "RGBA").save(tmp, format="PNG")
    if not quiet:
        console.print(f"wrote {output} ({w}×{h}, {technique})")
