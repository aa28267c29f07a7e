"""``terrascape bench report`` — the measurements of both theses as one Markdown report."""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.cli.app import bench_app, out, progress


@bench_app.command("report")
def report(
    output: Path = typer.Option(Path("docs/report"), "--output", "-o",
                                help="Folder for report.md and its PNG plots (created)."),
    quick: bool = typer.Option(False, "--quick", help="Small sizes (under 5 minutes)."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress bar."),
) -> None:
    """Run the benchmark suite and write a Markdown report with plots."""
    from terrascape.bench.report import write_report

    with progress(quiet=quiet) as bar:
        task = bar.add_task("report", total=None)

        def step(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        path = write_report(output, quick=quick, progress=step)
    out.print(f"wrote {path}")
