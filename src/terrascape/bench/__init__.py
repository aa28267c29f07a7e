"""Benchmarks (not tests): each ``bench/<name>.py`` case module defines ``run(quick=False)``.

A case returns a list of :class:`BenchTable`; ``terrascape bench NAME`` and
``python -m terrascape.bench NAME`` print them. The report (``bench report``) reuses the
same tables. Cases are discovered by module name, so adding one edits no shared list.
"""

from __future__ import annotations

import importlib
import pkgutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from terrascape.errors import InvalidParameterError

_NOT_CASES = {"__main__", "report", "report_analysis"}


@dataclass
class BenchTable:
    """One printed table: a title, column names, rows of values, and free-text notes."""

    title: str
    columns: list[str]
    rows: list[list[Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def to_markdown(self) -> str:
        def fmt(v: Any) -> str:
            if isinstance(v, float):
                return f"{v:.4g}"
            return str(v)

        lines = [f"### {self.title}", "", "| " + " | ".join(self.columns) + " |"]
        lines.append("|" + "|".join("---" for _ in self.columns) + "|")
        lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in self.rows]
        lines += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(lines) + "\n"


def available_cases() -> list[str]:
    """Names of the benchmark cases shipped in this package."""
    return sorted(
        m.name for m in pkgutil.iter_modules(__path__) if m.name not in _NOT_CASES
        and not m.name.startswith("_")
    )


def get_case(name: str) -> Callable[..., list[BenchTable]]:
    """The ``run`` function of case ``name``."""
    if name not in available_cases():
        raise InvalidParameterError(
            f"unknown benchmark {name!r}; available: {', '.join(available_cases())}"
        )
    return importlib.import_module(f"{__name__}.{name}").run


def best_of(func: Callable[[], Any], *, repeat: int = 3, warmup: int = 1) -> float:
    """Best wall time in seconds of ``repeat`` calls after ``warmup`` untimed calls."""
    for _ in range(warmup):
        func()
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def print_tables(tables: Sequence[BenchTable]) -> None:
    """Print tables with rich."""
    from rich.console import Console
    from rich.table import Table

    console = Console(highlight=False)
    for t in tables:
        table = Table(title=t.title)
        for c in t.columns:
            table.add_column(c)
        for row in t.rows:
            table.add_row(*(f"{v:.4g}" if isinstance(v, float) else str(v) for v in row))
        console.print(table)
        for n in t.notes:
            console.print(f"  [dim]{n}[/]")


__all__ = ["BenchTable", "available_cases", "best_of", "get_case", "print_tables"]
