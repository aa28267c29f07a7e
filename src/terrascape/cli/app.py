"""The typer application, shared helpers for commands, and error → exit-code mapping.

Exit codes (``docs/reliability.md``): 0 success; 2 usage error (bad option or value, bad
input file, output exists); 1 environment failure (disk full, read-only, permission denied,
not enough memory); 128 + N for signal N (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), after the
line "interrupted …; nothing was written".
"""

from __future__ import annotations

import contextlib
import signal
import time
from collections.abc import Iterator

import typer

try:  # typer >= 0.20 vendors click; its exceptions are the ones raised
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - older typer on the real click
    from click import exceptions as click_errors
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from terrascape.errors import Interrupted, TerrascapeError

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


def fail(message: str) -> None:
    """Print one red error line and exit with the usage-error code (no traceback)."""
    raise TerrascapeError(message)


#: ``--max-memory`` for commands that estimate their peak memory before allocating.
MAX_MEMORY = typer.Option(
    None, "--max-memory", metavar="SIZE",
    help="Refuse to start when the estimated peak memory exceeds SIZE (4G, 512M, 50%); "
         "default 80% of the memory available now (or $TERRASCAPE_MAX_MEMORY).",
    show_default=False,
)


def use_max_memory(value: str | None) -> None:
    """Apply a command's ``--max-memory`` (``None``: the default limit)."""
    from terrascape.memory import set_limit

    set_limit(value)


_SIGNALS = tuple(s for s in (getattr(signal, n, None) for n in ("SIGINT", "SIGTERM", "SIGHUP"))
                 if s is not None)


def _raise_interrupted(signum: int, _frame: object) -> None:
    raise Interrupted(signum)


@contextlib.contextmanager
def _signals_raise() -> Iterator[None]:
    """Turn SIGINT/SIGTERM/SIGHUP into :class:`Interrupted` while a command runs.

    The exception unwinds through every ``finally``, so unfinished outputs' temporary files
    are removed (``io.atomic``); the previous handlers come back afterwards.
    """
    previous = {}
    try:
        for sig in _SIGNALS:
            with contextlib.suppress(ValueError, OSError):  # not the main thread
                previous[sig] = signal.signal(sig, _raise_interrupted)
        yield
    finally:
        for sig, handler in previous.items():
            with contextlib.suppress(ValueError, OSError, TypeError):
                signal.signal(sig, handler)


def _usage_line(exc: click_errors.ClickException) -> str:
    """Click's usage error as one line: the message and where to read the help."""
    message = " ".join(exc.format_message().split())
    ctx = getattr(exc, "ctx", None)
    if ctx is not None and isinstance(exc, click_errors.UsageError):
        return f"{message} (see '{ctx.command_path} --help')"
    return message


def _error(message: str) -> None:
    # escape: a path or value such as "[0, 1]" in the message is text, not rich markup.
    console.print(f"[bold red]error:[/] {escape(message)}", markup=True, highlight=False)


def run_app(argv: list[str] | None = None) -> int:
    """Run the typer app and map every failure to one line on stderr and an exit code.

    ``TerrascapeError`` → its ``exit_code`` (2 usage, 1 environment); click's usage errors
    (unknown option, value out of range) → 2; an ``OSError`` or ``MemoryError`` no command
    turned into a typed error → 1; SIGINT/SIGTERM/SIGHUP → 128 + signal number, after the
    temporary files of unfinished outputs were removed.
    """
    from terrascape.io.atomic import committed_outputs, describe_os_error, reset_committed

    reset_committed()
    use_max_memory(None)  # a previous in-process run's --max-memory does not carry over
    try:
        with _signals_raise():
            try:
                result = app(args=argv, prog_name="terrascape", standalone_mode=False)
            except KeyboardInterrupt:  # raised by code that installs its own SIGINT handler
                raise Interrupted(signal.SIGINT) from None
    except Interrupted as exc:
        done = committed_outputs()
        if done:  # e.g. the heightmap was written, its --preview was not
            kept = ", ".join(str(p) for p in done)
            console.print(f"[red]interrupted ({exc.signal_name})[/]; finished before the "
                          f"signal and kept: {escape(kept)}; unfinished outputs were removed")
        else:
            console.print(f"[red]interrupted ({exc.signal_name}); nothing was written[/] "
                          "(unfinished outputs were removed)")
        return exc.exit_code
    except TerrascapeError as exc:
        _error(str(exc))
        return exc.exit_code
    except click_errors.NoArgsIsHelpError as exc:
        if exc.ctx is not None:  # a group without its command: show its help, as before
            out.print(exc.ctx.get_help())
        return exc.exit_code
    except click_errors.ClickException as exc:
        _error(_usage_line(exc))
        return exc.exit_code
    except typer.Abort:
        _error("aborted; nothing was written")
        return 1
    except MemoryError:
        _error("out of memory: the machine could not allocate what this command needs; "
               "nothing was written. Use a smaller size, or free memory and try again")
        return 1
    except OSError as exc:
        _error(describe_os_error(exc, verb="cannot access"))
        return 1
    except SystemExit as exc:
        code = exc.code
        return code if isinstance(code, int) else (0 if code is None else 1)
    return result if isinstance(result, int) and not isinstance(result, bool) else 0


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
