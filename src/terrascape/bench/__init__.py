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


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


@dataclass(frozen=True)
class Target:
    """A stated target and whether this run met it.

    ``measured`` is ``None`` when the run did not measure it (e.g. ``--quick`` runs smaller
    sizes than the target names); ``met`` is then ``None`` too.
    """

    what: str
    limit: float
    at_most: bool
    unit: str
    measured: float | None

    @property
    def met(self) -> bool | None:
        if self.measured is None:
            return None
        return self.measured <= self.limit if self.at_most else self.measured >= self.limit

    def describe(self) -> str:
        bound = f"{'≤' if self.at_most else '≥'} {_fmt(float(self.limit))}{self.unit}"
        if self.measured is None:
            return f"{self.what} {bound} (not measured in this run)"
        return f"{self.what} {bound}: {_fmt(float(self.measured))}{self.unit}"


@dataclass
class BenchTable:
    """One printed table: a title, column names, rows of values, free-text notes, and the
    targets it checks (:meth:`check_target`; every printout ends with which were met)."""

    title: str
    columns: list[str]
    rows: list[list[Any]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    targets: list[Target] = field(default_factory=list)

    def value(self, row: str, column: str) -> float | None:
        """The number in the row labelled ``row`` (first cell) and column ``column``, or
        ``None`` when this run has no such row or column (e.g. a size ``--quick`` skips)."""
        if column not in self.columns:
            return None
        k = self.columns.index(column)
        for r in self.rows:
            if r and str(r[0]) == row and k < len(r) and isinstance(r[k], int | float):
                return float(r[k])
        return None

    def check_target(self, what: str, measured: float | None, *, at_most: float | None = None,
                     at_least: float | None = None, unit: str = "") -> Target:
        """Record target ``what`` (exactly one of ``at_most``/``at_least``) against the
        ``measured`` value (``None``: not measured in this run)."""
        if (at_most is None) == (at_least is None):
            raise InvalidParameterError("give exactly one of at_most / at_least")
        limit = at_most if at_most is not None else at_least
        target = Target(what, float(limit), at_most is not None, unit,
                        None if measured is None else float(measured))
        self.targets.append(target)
        return target

    def to_markdown(self) -> str:
        lines = [f"### {self.title}", "", "| " + " | ".join(self.columns) + " |"]
        lines.append("|" + "|".join("---" for _ in self.columns) + "|")
        lines += ["| " + " | ".join(_fmt(v) for v in row) + " |" for row in self.rows]
        lines += [""] + [f"- {n}" for n in self.notes]
        lines += [f"- target {'met' if t.met else 'MISSED' if t.met is False else 'not run'}: "
                  f"{t.describe()}" for t in self.targets]
        return "\n".join(lines) + "\n"

    def to_csv(self) -> str:
        """The table as CSV (title and notes as ``#`` comment lines)."""
        import csv
        import io

        buf = io.StringIO()
        buf.write(f"# {self.title}\n")
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.columns)
        writer.writerows([[_fmt(v) for v in row] for row in self.rows])
        buf.writelines(f"# {n}\n" for n in self.notes)
        return buf.getvalue()


def targets_summary(tables: Sequence[BenchTable]) -> str:
    """The closing line of a benchmark run: which stated targets it met and missed."""
    targets = [t for table in tables for t in table.targets]
    if not targets:
        return "targets: none stated for this benchmark"
    met = [t for t in targets if t.met]
    missed = [t for t in targets if t.met is False]
    not_run = [t for t in targets if t.met is None]
    parts = [f"targets: {len(met)} met, {len(missed)} missed"
             + (f", {len(not_run)} not measured in this run" if not_run else "")]
    if missed:
        parts.append("missed: " + "; ".join(t.describe() for t in missed))
    if met:
        parts.append("met: " + "; ".join(t.describe() for t in met))
    return " — ".join(parts)


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


#: ``--format`` choices of ``terrascape bench NAME``.
OUTPUT_FORMATS = ("table", "md", "csv")


def print_tables(tables: Sequence[BenchTable], fmt: str = "table", *, file=None) -> None:
    """Print tables as rich tables (full width when not on a terminal), Markdown or CSV,
    then the :func:`targets_summary` line."""
    from rich.markup import escape
    from rich.table import Table

    from terrascape._output import make_console

    if fmt not in OUTPUT_FORMATS:
        raise InvalidParameterError(
            f"--format must be one of {', '.join(OUTPUT_FORMATS)}, got {fmt!r}")
    console = make_console(file=file)
    if fmt != "table":
        text = "\n".join(t.to_markdown() if fmt == "md" else t.to_csv() for t in tables)
        summary = targets_summary(tables)
        console.out(text + ("\n" if fmt == "md" else "") + (
            f"**{summary}**" if fmt == "md" else f"# {summary}"), highlight=False)
        return
    for t in tables:
        table = Table(title=t.title)
        for c in t.columns:
            table.add_column(c)
        for row in t.rows:
            table.add_row(*(f"{v:.4g}" if isinstance(v, float) else str(v) for v in row))
        console.print(table)
        for n in t.notes:
            console.print(f"  [dim]{escape(n)}[/]")
        for target in t.targets:
            verdict = {True: "[green]met[/]", False: "[red]MISSED[/]", None: "[dim]not run[/]"}
            console.print(f"  target {verdict[target.met]}: {escape(target.describe())}")
    console.print(escape(targets_summary(tables)))


__all__ = ["OUTPUT_FORMATS", "BenchTable", "Target", "available_cases", "best_of", "get_case",
           "print_tables", "targets_summary"]
