"""Benchmark output for people and for logs: full-width tables, Markdown/CSV, targets line,
and progress lines when stderr is not a terminal."""

from __future__ import annotations

import csv
import io

import pytest

from terrascape._output import LineProgress, make_console
from terrascape.bench import BenchTable, print_tables, targets_summary
from terrascape.cli import run_app


def _tables() -> list[BenchTable]:
    wide = BenchTable(
        title="A table wider than any terminal",
        columns=["technique", *[f"a rather long column name {k} ms/frame" for k in range(6)]],
        rows=[["relief_by_distance", *[1000.0 / (k + 1) for k in range(6)]],
              ["parallax_limited", *[2.5 * k for k in range(6)]]],
        notes=["a note"],
    )
    wide.check_target("relief 1280×720", wide.value("relief_by_distance", wide.columns[1]),
                      at_most=100, unit=" ms")  # 1000: missed
    wide.check_target("parallax, column 3", wide.value("parallax_limited", wide.columns[3]),
                      at_most=10, unit=" ms")  # 5: met
    wide.check_target("at 4097²", wide.value("parallax_limited", "4097²"), at_least=30)
    return [wide]


def test_value_and_targets():
    (table,) = _tables()
    assert table.value("parallax_limited", table.columns[2]) == 2.5
    assert table.value("nope", table.columns[2]) is None
    assert [t.met for t in table.targets] == [False, True, None]
    line = targets_summary([table])
    assert line.startswith("targets: 1 met, 1 missed, 1 not measured in this run")
    assert "missed: relief 1280×720 ≤ 100 ms: 1000 ms" in line
    assert "met: parallax, column 3 ≤ 10 ms: 5 ms" in line
    assert targets_summary([BenchTable("t", ["a"])]) == "targets: none stated for this benchmark"
    with pytest.raises(Exception, match="exactly one"):
        table.check_target("x", 1.0)


def test_rich_table_is_not_cut_when_not_a_terminal(monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    buf = io.StringIO()
    print_tables(_tables(), file=buf)
    text = buf.getvalue()
    assert "…" not in text
    assert "relief_by_distance" in text and "a rather long column name 5 ms/frame" in text
    assert max(len(line) for line in text.splitlines()) > 200  # one row per line
    assert text.rstrip().splitlines()[-1].startswith("targets: 1 met, 1 missed")
    assert "target MISSED: relief 1280×720" in text


def test_markdown_and_csv():
    buf = io.StringIO()
    print_tables(_tables(), "md", file=buf)
    md = buf.getvalue()
    assert "| relief_by_distance | 1000 |" in md
    assert "- target MISSED: relief 1280×720 ≤ 100 ms: 1000 ms" in md
    assert md.rstrip().endswith("**")
    buf = io.StringIO()
    print_tables(_tables(), "csv", file=buf)
    rows = list(csv.reader(line for line in buf.getvalue().splitlines()
                           if not line.startswith("#")))
    assert rows[0][0] == "technique" and rows[1][:2] == ["relief_by_distance", "1000"]
    assert buf.getvalue().rstrip().splitlines()[-1].startswith("# targets: 1 met")


def test_bench_command_format_option(monkeypatch, capsys):
    import terrascape.cli.cmd_bench as cmd_bench

    monkeypatch.setattr(cmd_bench, "get_case", lambda name: lambda quick=False: _tables())
    assert run_app(["bench", "texture", "--format", "csv"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# A table wider") and "# targets: 1 met, 1 missed" in out
    assert run_app(["bench", "texture", "--markdown"]) == 0
    assert "### A table wider" in capsys.readouterr().out
    assert run_app(["bench", "texture", "--format", "xml"]) == 2


def test_line_progress_for_logs():
    buf = io.StringIO()
    console = make_console(file=buf)
    with LineProgress(console, min_interval=0.0) as bar:
        task = bar.add_task("report", total=4)
        for _ in range(4):
            bar.advance(task)
        bar.update(task, completed=4)  # no change: no line
    lines = buf.getvalue().splitlines()
    assert [ln.split(",")[0] for ln in lines] == [
        "report: at 1/4 (25%)", "report: at 2/4 (50%)", "report: at 3/4 (75%)",
        "report: at 4/4 (100%)", "report: done 4/4 (100%)"]
    quiet = io.StringIO()
    with LineProgress(make_console(file=quiet), disable=True, min_interval=0.0) as bar:
        bar.advance(bar.add_task("x", total=2))
    assert quiet.getvalue() == ""


def test_cli_progress_is_lines_when_stderr_is_not_a_terminal():
    from terrascape.cli.app import console, progress

    assert not console.is_terminal  # pytest captures stderr
    assert isinstance(progress(), LineProgress)
