"""The typer application, shared helpers for commands, and error → exit-code mapping."""

from __future__ import annotations

import contextlib
import time
import warnings
from collections.abc import Callable, Iterator

import typer
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from typer.core import TyperOption

from terrascape import __version__
from terrascape._output import LineProgress, make_console
from terrascape.errors import TerrascapeError

app = typer.Typer(
    name="terrascape",
    help="Generate, texture, shade and render terrain — with or without a GPU.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
bench_app = typer.Typer(
    help="Benchmarks: print timing tables (also `python -m terrascape.bench NAME`).",
    no_args_is_help=True,
)
app.add_typer(bench_app, name="bench")

# Full width when piped to a file or a log (rich would cut tables at 80 columns), one record
# per line; messages, warnings and progress go to stderr.
console = make_console(stderr=True)
out = make_console()

USAGE_EXIT = 2

#: Optional modules → the extra that installs them, for a one-line "pip install" message.
OPTIONAL_MODULES: dict[str, str] = {
    "moderngl": "render",
    "glcontext": "render",
    "imageio": "render",
    "imageio_ffmpeg": "render",
    "moderngl_window": "viewer",
    "pyglet": "viewer",
    "matplotlib": "report",
    "rasterio": "geo",
    "OpenEXR": "exr",
    "Imath": "exr",
    "pygltflib": "export",
    "trimesh": "export",
    "quantized_mesh_encoder": "export",
    "dask": "world",
    "distributed": "world",
    "zarr": "world",
    "pymartini": "bench",
    "pydelatin": "bench",
    "panda3d": "bench",
}


def missing_module_message(exc: ModuleNotFoundError) -> str | None:
    """One line naming the pip command for a missing optional module, or ``None`` when the
    missing module is not an optional dependency (a real bug: let the traceback show)."""
    name = (exc.name or "").split(".")[0]
    if not name or name == "terrascape":
        return None
    extra = OPTIONAL_MODULES.get(name)
    if extra is None:
        return f"the Python module {name!r} is not installed; install it with: pip install {name}"
    return (f"this needs the optional module {name!r}; install it with: "
            f"pip install 'terrascape[{extra}]'")


def _technique_list() -> str:
    from terrascape.render.techniques import technique_names

    return ", ".join(technique_names())


def _relief_technique_list() -> str:
    from terrascape.render.relief_techniques import QUAD_TECHNIQUE

    return ", ".join(QUAD_TECHNIQUE)


#: Placeholders an option's help may contain, filled from the registries only when help is
#: shown: the registries import the renderer (seconds), which `terrascape info` must not pay.
HELP_CHOICES: dict[str, Callable[[], str]] = {
    "{techniques}": _technique_list,
    "{relief_techniques}": _relief_technique_list,
}


def _get_help(self) -> str | None:
    text = self.__dict__.get("_raw_help")
    if text:
        for marker, fill in HELP_CHOICES.items():
            if marker in text:
                text = text.replace(marker, fill())
    return text


def _set_help(self, value: str | None) -> None:
    self.__dict__["_raw_help"] = value


TyperOption.help = property(_get_help, _set_help)  # type: ignore[assignment]

# Flags (--force, --quiet, --help) take no value: show no "<bool>" type next to them.
_display_type_rich = TyperOption.display_type_rich


def _flag_display_type(self: TyperOption, ctx) -> str | None:
    if self.is_flag and self.metavar is None:
        return None
    return _display_type_rich(self, ctx)


TyperOption.display_type_rich = _flag_display_type  # type: ignore[method-assign]


def _print_version(value: bool) -> None:
    if value:
        out.print(f"terrascape {__version__}")
        raise typer.Exit()


@app.callback()
def _main_options(
    version: bool = typer.Option(
        False, "--version", callback=_print_version, is_eager=True,
        help="Print the terrascape version and exit."),
) -> None:
    pass


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Warnings as one yellow line on stderr (not Python's two-line source-quoting form)."""
    console.print(f"[yellow]warning:[/] {escape(str(message))}")


def run_app(argv: list[str] | None = None) -> int:
    """Run the typer app; typed errors become one line on stderr and exit code 2.

    Usage errors (unknown option, bad value) are click's own and also exit with 2.
    """
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            app(args=argv, prog_name="terrascape")
    except TerrascapeError as exc:
        console.print(f"[bold red]error:[/] {escape(str(exc))}")
        return USAGE_EXIT
    except ModuleNotFoundError as exc:
        message = missing_module_message(exc)
        if message is None:
            raise
        console.print(f"[bold red]error:[/] {escape(message)}")
        return USAGE_EXIT
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    except KeyboardInterrupt:
        console.print("[red]interrupted[/]")
        return 130
    return 0


@contextlib.contextmanager
def timed(stage: str, *, quiet: bool = False) -> Iterator[None]:
    """Print ``stage… 0.12 s`` to stderr after the block (hmm-style per-stage timing)."""
    start = time.perf_counter()
    yield
    if not quiet:
        console.print(f"[dim]{stage}… {time.perf_counter() - start:.2f} s[/]")


def progress(*, quiet: bool = False) -> Progress | LineProgress:
    """A rich progress bar on stderr (disabled with ``--quiet``); when stderr is not a
    terminal (a log, CI), a plain progress line every few seconds instead."""
    if not console.is_terminal:
        return LineProgress(console, disable=quiet)
    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=console,
        disable=quiet,
        transient=True,
    )
