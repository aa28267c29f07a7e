"""The ``terrascape`` command line: a thin typer layer over the library.

Commands live in ``cli/cmd_*.py`` modules, each registering on :data:`app`, and are listed
in :data:`~terrascape.cli.commands.COMMANDS`. A command's module is imported when the command
runs, so ``terrascape --help`` imports none of them (see :class:`~terrascape.cli.app.
LazyCommandGroup`); :func:`load_command_modules` imports them all. The top-level help
(``terrascape``, ``--help``, ``-h``) does not even import typer: :mod:`~terrascape.cli.
quick_help` prints it from the command table.
"""

from __future__ import annotations

import sys

from terrascape._lazy import lazy_exports
from terrascape.cli.quick_help import print_quick_help

TYPE_CHECKING = False
if TYPE_CHECKING:
    from terrascape.cli.app import app, load_command_modules

__getattr__, __dir__ = lazy_exports(__name__, {"app": ("app", "load_command_modules")})


def run_app(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``) and return its exit code
    (see :func:`terrascape.cli.app.run_app`); the top-level help is printed without typer."""
    code = print_quick_help(sys.argv[1:] if argv is None else list(argv))
    if code is not None:
        return code
    from terrascape.cli.app import run_app as run_typer_app

    return run_typer_app(argv)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    sys.exit(run_app(argv))


__all__ = ["app", "load_command_modules", "main", "run_app"]
