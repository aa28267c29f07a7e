"""``terrascape bench NAME`` — one sub-command per benchmark case module."""

from __future__ import annotations

import typer

from terrascape.bench import available_cases, get_case, print_tables
from terrascape.cli.app import bench_app


def _make_command(name: str) -> None:
    def command(
        quick: bool = typer.Option(False, "--quick", help="Small sizes, same table layout."),
        markdown: bool = typer.Option(
            False, "--markdown", "-m",
            help="Print Markdown tables (every column in full, for files and pipes)."),
    ) -> None:
        tables = get_case(name)(quick=quick)
        if markdown:
            typer.echo("\n".join(t.to_markdown() for t in tables))
        else:
            print_tables(tables)

    command.__doc__ = f"Run the {name!r} benchmark and print its tables."
    bench_app.command(name=name)(command)


for _name in available_cases():  # `bench report` is cli/cmd_report.py (not a case)
    _make_command(_name)
