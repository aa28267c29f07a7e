"""The ``terrascape`` command line: a thin typer layer over the library.

Commands live in ``cli/cmd_*.py`` modules, each registering on :data:`app`; they are
discovered here so that adding a command never means editing a shared list.
"""

from __future__ import annotations

import importlib
import pkgutil
import sys

from terrascape.cli.app import app, run_app


def _load_commands() -> None:
    for module in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if module.name.startswith("cmd_"):
            importlib.import_module(f"{__name__}.{module.name}")


_load_commands()


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point."""
    sys.exit(run_app(argv))


__all__ = ["app", "main"]
