"""Console output that suits people and logs alike.

On a terminal rich draws tables at the terminal's width and live progress bars. Piped to a
file or a log, rich would cut every table to 80 columns ("ms/fr…") and a transient progress
bar would print nothing at all, so there tables get all the width they need and progress is
a plain line on stderr now and then. ``COLUMNS`` set in the environment always wins.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Any

from rich.console import Console, ConsoleDimensions

#: Width given to output that is not a terminal: wide enough for any table, which rich then
#: draws at its natural width (tables do not expand to the console's width).
LOG_WIDTH = 10_000


class AdaptiveConsole(Console):
    """A rich console whose width is the terminal's, or :data:`LOG_WIDTH` when the output is
    not a terminal (decided at every print, so a redirected ``sys.stdout`` is honoured)."""

    @property
    def size(self) -> ConsoleDimensions:
        size = Console.size.fget(self)
        if not self.is_terminal and "COLUMNS" not in os.environ and self._width is None:
            return ConsoleDimensions(LOG_WIDTH, size.height)
        return size

    @size.setter
    def size(self, new_size: tuple[int, int]) -> None:
        Console.size.fset(self, new_size)


def make_console(*, stderr: bool = False, **kwargs: Any) -> AdaptiveConsole:
    """The console every command prints with (``stderr=True``: messages and progress)."""
    return AdaptiveConsole(stderr=stderr, highlight=False, soft_wrap=True, **kwargs)


class LineProgress:
    """Progress for logs: the subset of :class:`rich.progress.Progress` the commands use,
    printed as ``description: 3/12 (25%), 41.2 s`` lines on ``console`` (stderr), at most one
    every ``min_interval`` seconds, plus a closing line when any was printed."""

    def __init__(self, console: Console, *, disable: bool = False,
                 min_interval: float = 5.0) -> None:
        self.console = console
        self.disable = disable
        self.min_interval = float(min_interval)
        self._tasks: dict[int, dict[str, Any]] = {}
        self._start = time.perf_counter()
        self._last = -float("inf")
        self._printed = False

    def __enter__(self) -> LineProgress:
        self._start = time.perf_counter()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None and self._printed and not self.disable:
            for task in self._tasks.values():
                self._line(task, final=True)

    def add_task(self, description: str, total: float | None = None, **_: Any) -> int:
        key = len(self._tasks)
        self._tasks[key] = {"description": description, "total": total, "completed": 0.0}
        return key

    def advance(self, task_id: int, advance: float = 1.0) -> None:
        task = self._tasks[task_id]
        self.update(task_id, completed=task["completed"] + advance)

    def update(self, task_id: int, *, completed: float | None = None,
               total: float | None = None, description: str | None = None,
               **_: Any) -> None:
        task = self._tasks[task_id]
        if total is not None:
            task["total"] = total
        if description is not None:
            task["description"] = description
        if completed is None or completed == task["completed"]:
            return
        task["completed"] = completed
        now = time.perf_counter()
        if now - self._last >= self.min_interval:
            self._last = now
            self._line(task)

    def _line(self, task: dict[str, Any], *, final: bool = False) -> None:
        if self.disable:
            return
        self._printed = True
        done, total = task["completed"], task["total"]
        count = f"{done:g}/{total:g} ({100.0 * done / total:.0f}%)" if total else f"{done:g}"
        elapsed = time.perf_counter() - self._start
        state = "done" if final else "at"
        self.console.print(f"{task['description']}: {state} {count}, {elapsed:.1f} s",
                           markup=False)


def stream_is_terminal(stream=None) -> bool:
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


__all__ = ["LOG_WIDTH", "AdaptiveConsole", "LineProgress", "make_console",
           "stream_is_terminal"]
