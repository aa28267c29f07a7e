"""The typer application, shared helpers for commands, and error → exit-code mapping."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

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

console = Console(stderr=True, highlight=False, soft_wrap=True)
out = Console(highlight=False, soft_wrap=True)  # piped output stays one record per line

USAGE_EXIT = 2


def run_app(argv: list[str] | None = None) -> int:
    """Run the typer app; typed errors become one line on stderr and exit code 2.

    Usage errors (unknown option, bad value) are click's own and also exit with 2.
    """
    try:
        app(args=argv, prog_name="terrascape")
    except TerrascapeError as exc:
        console.print(f"[bold red]error:[/] {exc}")
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


def progress(*, quiet: bool = False) -> Progress:
    """A rich progress bar on stderr (disabled with ``--quiet``)."""
    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=console,
        disable=quiet,
        transient=True,
    )
