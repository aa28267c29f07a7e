"""``terrascape generate diamond-square|fault|hills`` and ``terrascape blur`` (H3–H6)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from terrascape.cli.app import MAX_MEMORY, app, out, progress, timed, use_max_memory
from terrascape.errors import FileFormatError, InvalidParameterError

if TYPE_CHECKING:
    from collections.abc import Callable

    from terrascape.heightmap import Heightmap

generate_app = typer.Typer(
    help="Generate a heightmap (diamond-square, fault formation, cosine hills) and write it.",
    no_args_is_help=True,
)
app.add_typer(generate_app, name="generate")

_PREVIEW_SUFFIXES = (".png", ".bmp")


# --- shared options ----------------------------------------------------------------------------
def _size_option(default: str) -> str:
    return typer.Option(default, "--size", help="Samples per side N, or COLSxROWS.")


_SEED = typer.Option(0, "--seed", help="Random seed (same seed → same bytes).")
_HEIGHT_SCALE = typer.Option(
    None, "--height-scale",
    help="Rescale heights to [0, METRES] (world units); default: the generator's raw heights.",
    show_default="raw",
)
_SPACING = typer.Option(1.0, "--spacing", help="Sample spacing in world units (metres).")
_OUTPUT = typer.Option(..., "--output", "-o",
                       help="Output heightmap (.png 16-bit, .r16/.raw, .r32, .tif, .npy, .ter).")
_PREVIEW = typer.Option(None, "--preview", help="Also write an 8-bit preview (.png or .bmp).",
                        show_default="none")
_FORCE = typer.Option(False, "--force", help="Overwrite existing output files.")
_QUIET = typer.Option(False, "--quiet", "-q", help="No progress bar or timing lines.")


def parse_grid_size(text: str) -> tuple[int, int]:
    """``"513"`` → ``(513, 513)``; ``"640x480"`` (cols×rows) → ``(480, 640)`` as (rows, cols)."""
    from terrascape.cli.parsing import parse_size

    t = text.strip()
    if t.isdigit():
        n = int(t)
        return (n, n)
    cols, rows = parse_size(t, name="--size")
    return (rows, cols)


def _check_outputs(output: Path, preview: Path | None, force: bool) -> None:
    """Fail before the (possibly long) generation if the outputs cannot be written."""
    from terrascape.io import WRITE_EXTENSIONS, check_output_path, formats_help

    if output.suffix.lower() not in WRITE_EXTENSIONS:
        raise FileFormatError(
            f"cannot write heightmaps as {output.suffix or '(no extension)'!r} "
            f"({output.name}); expected one of {formats_help(write=True)}"
        )
    check_output_path(output, force=force)
    if preview is not None:
        if preview.suffix.lower() not in _PREVIEW_SUFFIXES:
            raise FileFormatError(f"--preview must be a .png or .bmp path, got {preview.name!r}")
        if preview.resolve() == output.resolve():
            raise InvalidParameterError("--preview and --output must be different files")
        check_output_path(preview, force=force)


def _check_memory(command: str, shape: tuple[int, int], max_memory: str | None) -> None:
    """Refuse a grid whose estimated peak memory exceeds --max-memory, before allocating."""
    from terrascape.memory import check_grid

    use_max_memory(max_memory)
    check_grid(command, shape[0], shape[1], hint="use a smaller --size (or raise --max-memory)")


def _finish(hm: Heightmap, output: Path, preview: Path | None, height_scale: float | None,
            force: bool, quiet: bool) -> None:
    from terrascape._validate import check_positive
    from terrascape.io import write_heightmap, write_preview

    if height_scale is not None:
        hm = hm.normalised(0.0, check_positive(height_scale, "--height-scale"))
    with timed("write", quiet=quiet):
        write_heightmap(hm, output, force=force)
        if preview is not None:
            write_preview(hm, preview, force=force)
    out.print(
        f"wrote {output} ({hm.cols}×{hm.rows}, heights {hm.min:.4g} … {hm.max:.4g}, "
        f"spacing {hm.spacing[0]:g})" + (f"; preview {preview}" if preview else "")
    )


def _run_with_bar(label: str, total: int, quiet: bool,
                  make: Callable[[Callable[[int, int], None] | None], Heightmap]) -> Heightmap:
    """Run a chunked generator with a rich progress bar updated after every chunk."""
    bar = progress(quiet=quiet)
    with bar, timed(label, quiet=quiet):
        task = bar.add_task(label, total=total)

        def update(done: int, _total: int) -> None:
            bar.update(task, completed=done)

        return make(update)


# --- commands ----------------------------------------------------------------------------------
@generate_app.command("diamond-square")
def diamond_square_cmd(
    size: str = _size_option("513"),
    seed: int = _SEED,
    roughness: float = typer.Option(
        1.0, "--roughness", help="Offset amplitude of the first level (world units)."),
    decay: str = typer.Option(
        "halve", "--decay", help="Roughness decay per level: linear, halve, sqrt, hurst."),
    decay_step: float = typer.Option(
        None, "--decay-step", help="Decrement of the linear law (world units).",
        show_default="roughness / levels"),
    hurst: float = typer.Option(0.8, "--hurst", help="Hurst exponent H in [0, 1] (decay hurst)."),
    corners: str = typer.Option(
        None, "--corners", help="Fixed corner heights TL,TR,BL,BR (world units).",
        show_default="random"),
    integer: bool = typer.Option(
        False, "--integer", help="Seed 001's integer arithmetic (integer roughness/step)."),
    height_scale: float = _HEIGHT_SCALE,
    spacing: float = _SPACING,
    output: Path = _OUTPUT,
    preview: Path = _PREVIEW,
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Diamond-square fractal terrain on a (2**n + 1)² grid (seed 001 §2.2, §5.3.1)."""
    from terrascape.cli.parsing import parse_floats
    from terrascape.generate import diamond_square

    rows, cols = parse_grid_size(size)
    if rows != cols:
        raise InvalidParameterError(
            f"diamond-square needs a square size N = 2**n + 1, got {cols}x{rows}")
    corner_values = parse_floats(corners, 4, name="--corners") if corners else None
    _check_outputs(output, preview, force)
    _check_memory("diamond-square", (rows, cols), max_memory)
    with timed("diamond-square", quiet=quiet):
        hm = diamond_square(rows, roughness=roughness, decay=decay, decay_step=decay_step,
                            hurst=hurst, seed=seed, spacing=spacing, corners=corner_values,
                            integer=integer)
    _finish(hm, output, preview, height_scale, force, quiet)


@generate_app.command("fault")
def fault_cmd(
    size: str = _size_option("513"),
    seed: int = _SEED,
    iterations: int = typer.Option(1000, "--iterations", help="Number of fault lines."),
    start_displacement: float = typer.Option(
        1.0, "--start-displacement", help="Displacement of the first fault (world units)."),
    end_displacement: float = typer.Option(
        0.1, "--end-displacement", help="Displacement of the last fault (linear in between)."),
    falloff: str = typer.Option(
        "step", "--falloff", help="Profile across the line: step, sine, cosine."),
    width: float = typer.Option(
        8.0, "--width", help="Transition width across the line (samples; sine/cosine)."),
    height_scale: float = _HEIGHT_SCALE,
    spacing: float = _SPACING,
    output: Path = _OUTPUT,
    preview: Path = _PREVIEW,
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Fault-formation terrain: random lines raise one side and lower the other (§2.3)."""
    from terrascape._validate import check_int
    from terrascape.generate import fault_formation

    shape = parse_grid_size(size)
    total = check_int(iterations, "--iterations", minimum=1)
    _check_outputs(output, preview, force)
    _check_memory("fault", shape, max_memory)
    hm = _run_with_bar("fault formation", total, quiet, lambda cb: fault_formation(
        shape, iterations=iterations, start_displacement=start_displacement,
        end_displacement=end_displacement, falloff=falloff, width=width, seed=seed,
        spacing=spacing, progress=cb))
    _finish(hm, output, preview, height_scale, force, quiet)


@generate_app.command("hills")
def hills_cmd(
    size: str = _size_option("513"),
    seed: int = _SEED,
    count: int = typer.Option(1000, "--count", help="Number of hills."),
    radius_min: float = typer.Option(
        None, "--radius-min", help="Smallest hill radius (samples).", show_default="side/64"),
    radius_max: float = typer.Option(
        None, "--radius-max", help="Largest hill radius (samples).", show_default="side/16"),
    height: float = typer.Option(
        1.0, "--height", help="Hill height, the seed's 'odmak' (world units)."),
    height_scale: float = _HEIGHT_SCALE,
    spacing: float = _SPACING,
    output: Path = _OUTPUT,
    preview: Path = _PREVIEW,
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Cosine-hills terrain: h += d/2 + cos(pd·π)·d/2 inside each circle (§2.4)."""
    from terrascape._validate import check_int
    from terrascape.generate import hills
    from terrascape.generate.hills import default_radius_range

    shape = parse_grid_size(size)
    total = check_int(count, "--count", minimum=1)
    lo, hi = default_radius_range(*shape)
    radius = (lo if radius_min is None else radius_min, hi if radius_max is None else radius_max)
    _check_outputs(output, preview, force)
    _check_memory("hills", shape, max_memory)
    hm = _run_with_bar("hills", total, quiet, lambda cb: hills(
        shape, count=count, radius_range=radius, height=height, seed=seed, spacing=spacing,
        progress=cb))
    _finish(hm, output, preview, height_scale, force, quiet)


@app.command("blur")
def blur_cmd(
    input_path: Path = typer.Argument(..., metavar="IN", help="Input heightmap file."),
    output: Path = typer.Argument(..., metavar="OUT", help="Output heightmap file."),
    sigma: float = typer.Option(
        None, "--sigma", help="Gaussian standard deviation (samples).", show_default="none"),
    box: int = typer.Option(
        None, "--box", help="Box-filter window side (samples).", show_default="none"),
    mode: str = typer.Option(
        "reflect", "--mode", help="Border mode: reflect, nearest, mirror, wrap, constant."),
    force: bool = _FORCE,
    quiet: bool = _QUIET,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Smooth a heightmap on float heights (no 8-bit quantisation): --sigma S or --box N."""
    from terrascape.filters import box_blur, gaussian_blur
    from terrascape.io import read_heightmap
    from terrascape.memory import check_grid

    if (sigma is None) == (box is None):
        raise InvalidParameterError("give exactly one of --sigma S (Gaussian) or --box N (box)")
    _check_outputs(output, None, force)
    with timed("read", quiet=quiet):
        hm = read_heightmap(input_path)
    if sigma is not None:
        from terrascape.memory import gaussian_kernel_bytes

        use_max_memory(max_memory)
        check_grid("blur", hm.rows, hm.cols, extra=gaussian_kernel_bytes(sigma),
                   hint="a Gaussian much wider than the map only averages it: use a smaller "
                        "--sigma (or raise --max-memory)")
    with timed("blur", quiet=quiet):
        hm = gaussian_blur(hm, sigma, mode=mode) if sigma is not None else box_blur(
            hm, box, mode=mode)
    _finish(hm, output, None, None, force, quiet)


def _noise_command(kind: str) -> None:
    """Register ``generate fbm`` / ``generate ridged`` (same options; ridged adds --offset)."""

    def command(
        size: str = _size_option("513"),
        seed: int = _SEED,
        scale: float = typer.Option(128.0, "--scale", help="First-octave wavelength (samples)."),
        octaves: int = typer.Option(6, "--octaves", help="Number of octaves (1–24)."),
        lacunarity: float = typer.Option(2.0, "--lacunarity",
                                         help="Frequency ratio between octaves."),
        gain: float = typer.Option(0.5, "--gain", help="Amplitude ratio between octaves."),
        offset: float = typer.Option(1.0, "--offset",
                                     help="Ridge offset (ridged only, 0.5–2)."),
        amplitude: float = typer.Option(1.0, "--amplitude",
                                        help="Height amplitude (world units)."),
        height_scale: float = _HEIGHT_SCALE,
        spacing: float = _SPACING,
        output: Path = _OUTPUT,
        preview: Path = _PREVIEW,
        force: bool = _FORCE,
        quiet: bool = _QUIET,
        max_memory: str = MAX_MEMORY,
    ) -> None:
        from terrascape.generate import fbm, ridged

        shape = parse_grid_size(size)
        _check_outputs(output, preview, force)
        _check_memory(kind, shape, max_memory)
        kw = {"scale": scale, "octaves": octaves, "lacunarity": lacunarity, "gain": gain,
              "amplitude": amplitude, "seed": seed, "spacing": spacing}
        with timed(kind, quiet=quiet):
            hm = fbm(shape, **kw) if kind == "fbm" else ridged(shape, offset=offset, **kw)
        _finish(hm, output, preview, height_scale, force, quiet)

    command.__doc__ = (
        "Gradient-noise fBm terrain (sum of octaves; beyond the seeds)." if kind == "fbm"
        else "Ridged multifractal terrain (Musgrave; sharp ridges, smooth valleys)."
    )
    generate_app.command(kind)(command)


_noise_command("fbm")
_noise_command("ridged")
