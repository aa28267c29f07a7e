"""The ``terrascape`` command line: a thin typer layer over the library.

Commands live in ``cli/cmd_*.py`` modules, each registering on :data:`app`, and are listed
in :data:`~terrascape.cli.commands.COMMANDS`. A command's module is imported when the command
runs, so ``terrascape --help`` imports none of them (see :class:`~terrascape.cli.app.
LazyCommandGroup`); :func:`load_command_modules` imports them all.
"""

from __future__ import annotations

import sys

from terrascape.cli.app import app, load_command_modules, run_app


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    sys.exit(run_app(argv))


__all__ = ["app", "load_command_modules", "main", "run_app"]
