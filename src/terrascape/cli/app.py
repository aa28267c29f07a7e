"""The typer application, shared helpers for commands, and error → exit-code mapping.

Exit codes (``docs/reliability.md``): 0 success; 2 usage error (bad option or value, bad
input file, output exists); 1 environment failure (disk full, read-only, permission denied,
not enough memory); 128 + N for signal N (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP), after the
line "interrupted …; nothing was written".
"""

from __future__ import annotations

import contextlib
import difflib
import importlib
import inspect
import os
import signal
import sys
import threading
import time
import types
import warnings
from collections.abc import Callable, Iterable, Iterator
from typing import TYPE_CHECKING, Any

import typer

try:  # typer >= 0.20 vendors click; its exceptions are the ones raised
    from typer._click import exceptions as click_errors
except ImportError:  # pragma: no cover - older typer on the real click
    from click import exceptions as click_errors
from rich.markup import escape
from typer.core import TyperCommand, TyperGroup, TyperOption

from terrascape import __version__
from terrascape._interrupts import defer_interrupt
from terrascape._output import LineProgress, make_console
from terrascape.cli.commands import COMMANDS
from terrascape.cli.quick_help import DESCRIPTION
from terrascape.errors import Interrupted, TerrascapeError

if TYPE_CHECKING:
    from rich.progress import Progress


def load_command_modules(names: Iterable[str] | None = None) -> None:
    """Import the ``cli/cmd_*.py`` modules of the commands ``names`` (default: every
    ``cmd_*`` module in ``cli/``, listed in the table or not), so they register their
    commands on :data:`app`."""
    if names is None:
        import pkgutil

        import terrascape.cli

        modules = sorted(m.name for m in pkgutil.iter_modules(terrascape.cli.__path__)
                         if m.name.startswith("cmd_"))
    else:
        modules = [m for name in names for m in COMMANDS[name].modules]
    for module in modules:
        importlib.import_module(f"terrascape.cli.{module}")


def _reflow_help(info) -> None:
    """A command's help from its docstring with each paragraph on one line: typer keeps the
    source's line breaks, so a paragraph written 95 columns wide came out on an 80-column
    terminal as a long line and a stub ("... most of its time" / "compiling")."""
    if info.help is not None or info.callback is None or not info.callback.__doc__:
        return
    paragraphs = inspect.cleandoc(info.callback.__doc__).split("\n\n")
    info.help = "\n\n".join(" ".join(p.split()) for p in paragraphs)


class LazyCommandGroup(TyperGroup):
    """The top-level group: its command list comes from :data:`~terrascape.cli.commands.
    COMMANDS`, and a command's module is imported when the command is looked up to run (or
    to show its own help), not when ``terrascape --help`` lists it."""

    _listing = False

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._loaded: set[str] = set()
        self.suggest_commands = False  # typer's suggestions see only the loaded commands

    def resolve_command(self, ctx, args):
        try:
            return super().resolve_command(ctx, args)
        except click_errors.UsageError as exc:
            if args and exc.message.startswith("No such command"):
                matches = difflib.get_close_matches(args[0], self.list_commands(ctx))
                if matches:
                    exc.message = (f"{exc.message.rstrip('.')}. Did you mean "
                                   f"{', '.join(repr(m) for m in matches)}?")
            raise

    def list_commands(self, ctx) -> list[str]:
        return list(dict.fromkeys([*COMMANDS, *self.commands]))

    def get_command(self, ctx, cmd_name: str):
        entry = COMMANDS.get(cmd_name)
        if self._listing and entry is not None:
            return TyperCommand(name=cmd_name, help=entry.summary)
        if entry is not None and cmd_name not in self._loaded:
            self._loaded.add(cmd_name)
            load_command_modules([cmd_name])
            self._rebuild(cmd_name)
        return self.commands.get(cmd_name)

    def _rebuild(self, cmd_name: str) -> None:
        """Build the click command ``cmd_name`` from what its module registered on
        :data:`app` (this group was built before the module was imported)."""
        from typer.main import get_command_from_info, get_command_name, get_group_from_info

        for info in app.registered_commands:
            name = info.name or get_command_name(info.callback.__name__)
            if name == cmd_name:
                _reflow_help(info)
                self.commands[name] = get_command_from_info(
                    info, pretty_exceptions_short=app.pretty_exceptions_short,
                    rich_markup_mode=app.rich_markup_mode)
        for info in app.registered_groups:
            if info.name == cmd_name:
                for sub in info.typer_instance.registered_commands:
                    _reflow_help(sub)
                self.commands[cmd_name] = get_group_from_info(
                    info, pretty_exceptions_short=app.pretty_exceptions_short,
                    rich_markup_mode=app.rich_markup_mode,
                    suggest_commands=app.suggest_commands)

    def format_help(self, ctx, formatter) -> None:
        self._listing = True  # list the table's summaries: import no command module
        try:
            super().format_help(ctx, formatter)
        finally:
            self._listing = False


app = typer.Typer(
    cls=LazyCommandGroup,
    name="terrascape",
    help=DESCRIPTION,
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


def max_memory_option(refused: str):
    """``--max-memory``, its help starting with what is ``refused`` and when."""
    return typer.Option(
        None, "--max-memory", metavar="SIZE",
        help=f"{refused} when the estimated peak memory exceeds SIZE (4G, 512M, 50%); "
             "default 80% of the memory available now (or $TERRASCAPE_MAX_MEMORY).",
        show_default=False,
    )


#: ``--max-memory`` for commands that estimate their peak memory before allocating.
MAX_MEMORY = max_memory_option("Refuse to start")


def use_max_memory(value: str | None) -> None:
    """Apply a command's ``--max-memory`` (``None``: the default limit)."""
    from terrascape.memory import set_limit

    set_limit(value)


_SIGNALS = tuple(s for s in (getattr(signal, n, None) for n in ("SIGINT", "SIGTERM", "SIGHUP"))
                 if s is not None)


_resend_pending = False
_previous_unraisable_hook: Callable[[Any], None] = sys.__unraisablehook__


def _send_again_soon(signum: int) -> None:
    """The signal again a millisecond later, from another thread (sent from this one, it
    would be handled at once, where it was), to the main thread: by then the call in the
    way has returned. At most one is on its way: a signal handled while one is needs none
    of its own, and two would interrupt the first one's clean-up."""
    global _resend_pending
    if _resend_pending:
        return
    _resend_pending = True

    def send() -> None:
        global _resend_pending
        _resend_pending = False
        signal.pthread_kill(threading.main_thread().ident, signum)

    threading.Timer(0.001, send).start()


def _unraisable_hook(unraisable: Any) -> None:
    """``sys.unraisablehook`` while a command runs: a dropped :class:`Interrupted` is sent
    again.

    Python cannot pass on an exception raised in a callback from C (ctypes: numba's
    compiler calls one for every kernel it loads from its cache or compiles, for most of a
    command's first second) or in a finaliser (``__del__``): it prints "Exception ignored"
    and goes on. A signal handled there was lost, and the command ran to its end (seen:
    SIGTERM while `render --day-cycle` loaded its kernels, exit 0 and the video written).
    Sent again a millisecond later, it is handled after the callback has returned. Other
    dropped exceptions go to the hook that was there before."""
    if isinstance(unraisable.exc_value, Interrupted):
        _send_again_soon(unraisable.exc_value.signum)
        return
    _previous_unraisable_hook(unraisable)


# Code where the exception cannot be raised: it is sent again instead, until it lands
# elsewhere. numba turns a compiled call's result into Python objects in C, calling back
# into Python, and cannot pass on an exception raised there: a SystemError with a
# traceback, or a crash when the result held several arrays. llvmlite (numba's compiler)
# frees its objects in steps that an exception can cut in two: freed but not marked so, an
# object is freed again by its finaliser at the interpreter's exit (`render` signalled
# 0.3–1.2 s after its start: a segmentation fault after "nothing was written" in 1 run of
# 30, an AttributeError traceback from `ffi.py` `detach` in 1 of 25; `python
# scripts/signal_at_random.py --after-start --command "render …"`). Its Python steps
# around its C calls are short. And raised in the sending again itself (the
# hook above, a timer's start), it would be dropped for good.
_HELD_BY = (os.path.join("numba", "core", "serialize.py"), f"{os.sep}llvmlite{os.sep}")
_SENDING_AGAIN = (_unraisable_hook.__code__, _send_again_soon.__code__)


def _raised_later(frame: types.FrameType | None) -> bool:
    while frame is not None:
        code = frame.f_code
        if code in _SENDING_AGAIN or any(part in code.co_filename for part in _HELD_BY):
            return True
        frame = frame.f_back
    return False


def _raise_interrupted(signum: int, frame: types.FrameType | None) -> None:
    if defer_interrupt(signum):  # raised when the short section in the way ends
        return
    if _raised_later(frame):
        _send_again_soon(signum)
        return
    raise Interrupted(signum)


@contextlib.contextmanager
def _signals_raise() -> Iterator[None]:
    """Turn SIGINT/SIGTERM/SIGHUP into :class:`Interrupted` while a command runs.

    The exception unwinds through every ``finally``, so unfinished outputs' temporary files
    are removed (``io.atomic``); the previous handlers come back afterwards.
    """
    previous = {}
    previous_hook = sys.unraisablehook
    try:
        for sig in _SIGNALS:
            with contextlib.suppress(ValueError, OSError):  # not the main thread
                previous[sig] = signal.signal(sig, _raise_interrupted)
        if previous and previous_hook is not _unraisable_hook:  # not again when nested
            global _previous_unraisable_hook
            _previous_unraisable_hook = previous_hook
            sys.unraisablehook = _unraisable_hook
        yield
    finally:
        sys.unraisablehook = previous_hook
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


#: Outputs kept after a signal listed one by one up to this many.
_LISTED_KEPT = 50


def run_app(argv: list[str] | None = None) -> int:
    """Run the typer app and map every failure to one line on stderr and an exit code.

    ``TerrascapeError`` → its ``exit_code`` (2 usage, 1 environment); click's usage errors
    (unknown option, value out of range) → 2; an ``OSError`` or ``MemoryError`` no command
    turned into a typed error → 1; SIGINT/SIGTERM/SIGHUP → 128 + signal number, after the
    temporary files of unfinished outputs were removed.
    """
    from terrascape.io.atomic import (
        committed_in_bulk,
        committed_outputs,
        describe_os_error,
        reset_committed,
    )

    reset_committed()
    use_max_memory(None)  # a previous in-process run's --max-memory does not carry over
    try:
        with _signals_raise():
            try:
                with warnings.catch_warnings():
                    warnings.showwarning = _show_warning
                    result = app(args=argv, prog_name="terrascape", standalone_mode=False)
            except KeyboardInterrupt:  # raised by code that installs its own SIGINT handler
                raise Interrupted(signal.SIGINT) from None
    except Interrupted as exc:
        done = committed_outputs()
        bulk = committed_in_bulk()
        if done or bulk:  # e.g. the heightmap was written, its --preview was not
            kept = ", ".join(str(p) for p in done)
            total = len(done) + sum(count for count, _ in bulk)
            if total > _LISTED_KEPT:  # a tile pyramid's thousands: counted, not listed
                where = os.path.commonpath([str(p) for p in done] + [str(f) for _, f in bulk])
                kept = f"{total:,} files in {where}"
            console.print(f"[red]interrupted ({exc.signal_name})[/]; finished before the "
                          f"signal and kept: {escape(kept)}; unfinished outputs were removed")
        else:
            console.print(f"[red]interrupted ({exc.signal_name}); nothing was written[/] "
                          "(unfinished outputs were removed)")
        return exc.exit_code
    except TerrascapeError as exc:
        _error(str(exc))
        return exc.exit_code
    except ModuleNotFoundError as exc:
        message = missing_module_message(exc)
        if message is None:
            raise
        _error(message)
        return USAGE_EXIT
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


#: Seconds a stage with a ``slow_note`` runs before the note is printed.
SLOW_NOTE_AFTER = 5.0


@contextlib.contextmanager
def timed(stage: str, *, quiet: bool = False, slow_note: str | None = None) -> Iterator[None]:
    """Print ``stage… 0.12 s`` to stderr after the block (hmm-style per-stage timing).

    ``slow_note``: printed as ``stage: still working after 5 s — NOTE`` while the block
    is still running after :data:`SLOW_NOTE_AFTER` seconds (a first run that compiles for
    half a minute would otherwise look stuck)."""
    start = time.perf_counter()
    timer = None
    if slow_note and not quiet:
        import threading

        timer = threading.Timer(SLOW_NOTE_AFTER, lambda: console.print(
            f"[dim]{stage}: still working after {SLOW_NOTE_AFTER:g} s — {slow_note}[/]"))
        timer.daemon = True
        timer.start()
    try:
        yield
    finally:
        if timer is not None:
            timer.cancel()
    if not quiet:
        console.print(f"[dim]{stage}… {time.perf_counter() - start:.2f} s[/]")


def progress(*, quiet: bool = False) -> Progress | LineProgress:
    """A rich progress bar on stderr (disabled with ``--quiet``); when stderr is not a
    terminal (a log, CI), a plain progress line every few seconds instead."""
    if not console.is_terminal:
        return LineProgress(console, disable=quiet)
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>3.0f}%"),
        TimeElapsedColumn(),
        console=console,
        disable=quiet,
        transient=True,
    )
