"""``terrascape generate NAME`` (one sub-command per registered generator) and
``terrascape blur``."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from pathlib import Path

import typer

from terrascape._validate import check_positive
from terrascape.cli.app import MAX_MEMORY, app, console, out, progress, timed, use_max_memory
from terrascape.cli.parsing import parse_size
from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.generate.registry import (
    GENERATORS,
    Generator,
    Param,
    generate,
    names_help,
    progress_total,
)
from terrascape.heightmap import Heightmap
from terrascape.io import (
    WRITE_EXTENSIONS,
    check_output_path,
    formats_help,
    output_unit,
    read_heightmap,
    write_heightmap,
    write_preview,
)
from terrascape.memory import PEAK_BYTES_PER_SAMPLE, check_grid, gaussian_kernel_bytes

generate_app = typer.Typer(
    help=f"Generate a heightmap ({names_help()}) and write it. Heights span 0 … 20 % of the "
    "map's extent unless --height-scale or --raw says otherwise.",
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
    help="Heights span [0, METRES] (world units, the relief).",
    show_default="20 % of the map's extent",
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
    t = text.strip()
    if t.isdigit():
        n = int(t)
        return (n, n)
    cols, rows = parse_size(t, name="--size")
    return (rows, cols)


def _check_outputs(output: Path, preview: Path | None, force: bool) -> None:
    """Fail before the (possibly long) generation if the outputs cannot be written."""
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
    use_max_memory(max_memory)
    name = command if command in PEAK_BYTES_PER_SAMPLE else "fbm"
    check_grid(name, shape[0], shape[1], hint="use a smaller --size (or raise --max-memory)")


def _finish(hm: Heightmap, output: Path, preview: Path | None, height_scale: float | None,
            force: bool, quiet: bool) -> None:
    if height_scale is not None:
        hm = hm.normalised(0.0, check_positive(height_scale, "--height-scale"))
    # one unit: the heightmap and its preview appear together or not at all (a command
    # stopped between the two leaves neither)
    with timed("write", quiet=quiet), output_unit():
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


# --- commands: one per registered generator ---------------------------------------------------
_RAW = typer.Option(False, "--raw", help="Keep the generator's own heights (no relief scaling).")


def _param_option(param: Param) -> tuple[object, object]:
    """(annotation, typer.Option) for a registry parameter."""
    text = param.help
    if param.choices:
        text += f" One of: {', '.join(param.choices)}."
    show = param.auto if param.default is None and param.auto else True
    if param.type is bool:
        return bool, typer.Option(bool(param.default), param.option, help=text)
    annotation = str if param.count > 1 else param.type
    return annotation, typer.Option(param.default, param.option, help=text, show_default=show)


def _generator_command(gen: Generator, alias: str | None = None) -> Callable[..., None]:
    """A typer command for ``gen`` whose options are the registry's parameters (``alias``:
    an old spelling that still works, with a note)."""

    def command(**kwargs: object) -> None:
        if alias is not None:
            console.print(f"[yellow]note:[/] '{alias}' is an old name, use "
                          f"'terrascape generate {gen.name}'")
        size, seed, spacing = kwargs.pop("size"), kwargs.pop("seed"), kwargs.pop("spacing")
        height_scale, raw = kwargs.pop("height_scale"), kwargs.pop("raw")
        output, preview = kwargs.pop("output"), kwargs.pop("preview")
        force, quiet = kwargs.pop("force"), kwargs.pop("quiet")
        max_memory = kwargs.pop("max_memory")
        params = {}
        for param in gen.params:
            value = kwargs[param.name]
            if param.count > 1 and value is not None:
                value = param.parse(value)
            params[param.name] = value
        shape = parse_grid_size(size)
        if gen.square_pow2 and shape[0] != shape[1]:
            raise InvalidParameterError(
                f"{gen.name} needs a square size N = 2**n + 1, got {shape[1]}x{shape[0]}")
        if height_scale is not None and raw:
            raise InvalidParameterError("give either --height-scale or --raw, not both")
        if height_scale is not None:
            check_positive(height_scale, "--height-scale")
        total = progress_total(gen.name, shape, **params)
        _check_outputs(output, preview, force)
        _check_memory(gen.name, shape, max_memory)

        def make(callback: Callable[[int, int], None] | None) -> Heightmap:
            return generate(gen.name, shape, seed=seed, spacing=spacing, relief=height_scale,
                            raw=raw, progress=callback, **params)

        if total is None:
            with timed(gen.name, quiet=quiet):
                hm = make(None)
        else:
            hm = _run_with_bar(gen.name, total, quiet, make)
        _finish(hm, output, preview, None, force, quiet)

    options: list[tuple[str, object, object]] = [
        ("size", str, _size_option("513")),
        ("seed", int, _SEED),
        *[(p.name, *_param_option(p)) for p in gen.params],
        ("height_scale", float, _HEIGHT_SCALE),
        ("raw", bool, _RAW),
        ("spacing", float, _SPACING),
        ("output", Path, _OUTPUT),
        ("preview", Path, _PREVIEW),
        ("force", bool, _FORCE),
        ("quiet", bool, _QUIET),
        ("max_memory", str, MAX_MEMORY),
    ]
    command.__signature__ = inspect.Signature([  # type: ignore[attr-defined]
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option,
                          annotation=annotation)
        for name, annotation, option in options
    ])
    command.__annotations__ = {name: annotation for name, annotation, _ in options}
    command.__doc__ = gen.summary
    command.__name__ = gen.name.replace("-", "_") + "_cmd"
    return command


for _gen in GENERATORS.values():
    generate_app.command(_gen.name)(_generator_command(_gen))
    for _alias in _gen.aliases:
        generate_app.command(_alias, hidden=True)(_generator_command(_gen, _alias))


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
    from terrascape.filters import box_blur, gaussian_blur  # numba kernels: blur only

    if (sigma is None) == (box is None):
        raise InvalidParameterError("give exactly one of --sigma S (Gaussian) or --box N (box)")
    _check_outputs(output, None, force)
    with timed("read", quiet=quiet):
        hm = read_heightmap(input_path)
    if sigma is not None:
        use_max_memory(max_memory)
        check_grid("blur", hm.rows, hm.cols, extra=gaussian_kernel_bytes(sigma),
                   hint="a Gaussian much wider than the map only averages it: use a smaller "
                        "--sigma (or raise --max-memory)")
    with timed("blur", quiet=quiet):
        hm = gaussian_blur(hm, sigma, mode=mode) if sigma is not None else box_blur(
            hm, box, mode=mode)
    _finish(hm, output, None, None, force, quiet)

