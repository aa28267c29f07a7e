"""``terrascape``, ``terrascape --help`` and ``-h`` printed from the command table alone.

Importing typer loads rich, rich.markdown, markdown_it and rich.traceback (about half a
second on a loaded two-core machine, several times the interpreter's own start-up) only to
print one screen of text that depends on nothing but :data:`~terrascape.cli.commands.
COMMANDS`. This module draws that screen in typer's layout — the same lines, the same
boxes, the same wrapping of long summaries — with the standard library only, so the
top-level help loads neither typer, rich, numpy nor numba. ``tests/core/test_startup.py``
compares its text with typer's own help at several widths, so the two cannot drift apart.

Anything unusual falls back to typer: a terminal narrower than :data:`MIN_WIDTH` (where
rich starts shrinking columns), a ``dumb`` terminal, or the environment variables with
which rich and typer force or reshape colour output.
"""

from __future__ import annotations

import os
import sys

from terrascape.cli.commands import COMMANDS

#: The argument lists that ask for the top-level help (none at all: typer shows the help and
#: exits with the usage code, as for a missing command).
HELP_ARGS: dict[tuple[str, ...], int] = {(): 2, ("--help",): 0, ("-h",): 0}

#: Narrower than this, rich shrinks the columns differently; typer draws that help itself.
MIN_WIDTH = 50

#: The program's one-line description (also typer's ``help=``; ``cli/app.py`` uses it).
DESCRIPTION = "Generate, texture, shade and render terrain — with or without a GPU."
USAGE = "terrascape [OPTIONS] COMMAND [ARGS]..."

#: The top-level options as typer lays them out: long name, short name, help.
OPTIONS: tuple[tuple[str, str, str], ...] = (
    ("--version", "", "Print the terrascape version and exit."),
    ("--help", "-h", "Show this message and exit."),
)

# Environment variables with which rich or typer change colour or terminal detection: with
# any of them set, typer prints the help (what it does with them is its own business).
_STYLE_VARIABLES = ("FORCE_COLOR", "PY_COLORS", "GITHUB_ACTIONS", "TTY_COMPATIBLE",
                    "TTY_INTERACTIVE", "NO_COLOR", "_TYPER_FORCE_DISABLE_TERMINAL",
                    "JUPYTER_COLUMNS")

_RESET = "\x1b[0m"
_BOLD, _DIM, _YELLOW, _CYAN, _GREEN = "1", "2", "1;33", "1;36", "1;32"


def _paint(text: str, code: str, styled: bool) -> str:
    return f"\x1b[{code}m{text}{_RESET}" if styled and text else text


def _wrap(text: str, width: int) -> list[str]:
    """Words wrapped to ``width`` as rich wraps a table cell: greedily, at spaces, a word
    longer than the line folded. (Not ``textwrap``: it imports ``re``, a fifth of the
    quick help's own time.)"""
    lines: list[str] = []
    line = ""
    for word in text.split():
        while len(word) > width:  # fold: the line so far ends, the word fills whole lines
            if line:
                lines.append(line)
                line = ""
            lines.append(word[:width])
            word = word[width:]
        if not word:
            continue
        if not line:
            line = word
        elif len(line) + 1 + len(word) <= width:
            line = f"{line} {word}"
        else:
            lines.append(line)
            line = word
    lines.append(line)
    return lines


def _panel(title: str, rows: list[tuple[str, str, str]], width: int, styled: bool
           ) -> list[str]:
    """A rounded box ``width`` wide titled ``title``: each row is (plain prefix, its styled
    form, help text), the help wrapped in the column after the prefix."""
    inner = width - 2  # between the two borders
    top = "╭─" + f" {title} " + "─" * (inner - len(title) - 3) + "╮"
    lines = [_paint("╭─", _DIM, styled) + _paint(f" {title} ", _DIM, styled)
             + _paint(top[len(title) + 4:], _DIM, styled)]
    bar = _paint("│", _DIM, styled)
    for prefix, prefix_styled, help_text in rows:
        help_width = inner - 2 - len(prefix)  # one space of padding each side
        for k, piece in enumerate(_wrap(help_text, help_width)):
            lead = prefix_styled if k == 0 else " " * len(prefix)
            lines.append(f"{bar} {lead}{piece}{' ' * (help_width - len(piece))} {bar}")
    lines.append(_paint("╰" + "─" * inner + "╯", _DIM, styled))
    return lines


def top_level_help(width: int, *, styled: bool = False) -> str:
    """The text of ``terrascape --help`` for a terminal ``width`` columns wide (typer's
    layout, ``width`` ≥ :data:`MIN_WIDTH`), with terminal colours when ``styled``."""
    if width < MIN_WIDTH:
        raise ValueError(f"the quick help needs at least {MIN_WIDTH} columns, not {width}")
    blank = _paint(" " * width, _BOLD, styled)
    usage = (_paint(" ", _BOLD, styled) + _paint("Usage: ", _YELLOW, styled)
             + _paint(USAGE, _BOLD, styled)
             + _paint(" " * (width - len(USAGE) - 9), _BOLD, styled)
             + _paint(" ", _BOLD, styled))
    lines = [blank, usage, blank]
    lines += [f" {line}".ljust(width) for line in _wrap(DESCRIPTION, width - 2)]
    lines.append(" " * width)

    long_width = max(len(name) for name, _, _ in OPTIONS)
    short_width = max(len(short) for _, short, _ in OPTIONS)
    option_rows = []
    for name, short, help_text in OPTIONS:
        # typer's columns: long names, short names, an empty column for value types
        plain = f"{name:<{long_width}}  {short:<{short_width}}" + " " * 8
        painted = (_paint(name, _CYAN, styled) + " " * (long_width - len(name) + 2)
                   + _paint(short, _GREEN, styled) + " " * (short_width - len(short) + 8))
        option_rows.append((plain, painted, help_text))
    lines += _panel("Options", option_rows, width, styled)

    name_width = max(len(name) for name in COMMANDS)
    command_rows = [(f"{name:<{name_width}}  ",
                     _paint(f"{name:<{name_width}}", _CYAN, styled) + "  ", entry.summary)
                    for name, entry in COMMANDS.items()]
    lines += _panel("Commands", command_rows, width, styled)
    return "\n".join(lines) + "\n\n"


def terminal_width() -> int:
    """The width rich would give typer's help: ``TERMINAL_WIDTH`` (typer's setting), else
    ``COLUMNS``, else the terminal's size (stdin, stdout or stderr), else 80."""
    for variable in ("TERMINAL_WIDTH", "COLUMNS"):
        value = os.environ.get(variable, "")
        if value.isdigit():
            return int(value)
    for fd in (0, 1, 2):
        try:
            columns = os.get_terminal_size(fd).columns
        except (AttributeError, ValueError, OSError):
            continue
        return columns or 80
    return 80


def print_quick_help(args: list[str]) -> int | None:
    """Print the top-level help when ``args`` ask for it and return the exit code; ``None``
    when typer must run (other arguments, or a terminal this module does not draw for)."""
    code = HELP_ARGS.get(tuple(args))
    if code is None or any(v in os.environ for v in _STYLE_VARIABLES):
        return None
    stream = sys.stdout
    try:
        styled = stream.isatty()
    except (AttributeError, ValueError):
        return None
    if styled and os.environ.get("TERM", "").lower() in ("dumb", "unknown"):
        return None
    width = terminal_width()
    if width < MIN_WIDTH:
        return None
    stream.write(top_level_help(width, styled=styled))
    stream.flush()
    return code


__all__ = ["DESCRIPTION", "HELP_ARGS", "MIN_WIDTH", "print_quick_help", "terminal_width",
           "top_level_help"]
