"""``terrascape bench NAME`` — one sub-command per benchmark case module."""

from __future__ import annotations

import typer

from terrascape.bench import OUTPUT_FORMATS, available_cases, get_case, print_tables
from terrascape.cli.app import bench_app


def _make_command(name: str) -> None:
    def command(
        quick: bool = typer.Option(False, "--quick", help="Small sizes, same table layout."),
        fmt: str = typer.Option(
            "table", "--format", "-f",
            help=f"Output: {', '.join(OUTPUT_FORMATS)} (table: full width in files and pipes)."),
        markdown: bool = typer.Option(
            False, "--markdown", "-m", help="Same as --format md."),
    ) -> None:
        if fmt not in OUTPUT_FORMATS:  # before a run of minutes, not after
            from terrascape.errors import InvalidParameterError

            raise InvalidParameterError(
                f"--format must be one of {', '.join(OUTPUT_FORMATS)}, got {fmt!r}")
        tables = get_case(name)(quick=quick)
        print_tables(tables, "md" if markdown else fmt)

    command.__doc__ = (f"Run the {name!r} benchmark and print its tables and which of its "
                       "targets the run met.")
    bench_app.command(name=name)(command)


for _name in available_cases():  # `bench report` is cli/cmd_report.py (not a case)
    _make_command(_name)
