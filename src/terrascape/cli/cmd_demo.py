"""``terrascape demo`` — the README's first command runs this."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from terrascape.cli.app import app, out


@app.command()
def demo(
    output: Path = typer.Option(Path("demo-output"), "--output", "-o",
                                help="Folder for the images and heightmaps (created)."),
    size: int = typer.Option(513, "--size", help="Heightmap size in samples (2**n + 1)."),
    render_size: str = typer.Option("1280x720", "--render-size",
                                     help="Rendered image size WxH in pixels."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
    stages: str = typer.Option("generate,texture,render", "--stages",
                               help="Comma-separated stages to run (generate is always run)."),
) -> None:
    """Generate, texture, shade and render terrains; write everything to OUTPUT."""
    from terrascape.cli.demo import run_demo
    from terrascape.cli.parsing import parse_size

    if output.exists() and not output.is_dir():
        from terrascape.errors import FileFormatError

        raise FileFormatError(
            f"--output must be a folder (created if missing), but {output} is a file; "
            "give another folder name"
        )
    chosen = tuple(s.strip() for s in stages.split(",") if s.strip())
    result = run_demo(output, size=size, render_size=parse_size(render_size), force=force,
                      stages=chosen)
    table = Table(title=f"terrascape demo → {output}/", title_justify="left")
    table.add_column("file", no_wrap=True)
    table.add_column("what")
    table.add_column("time", justify="right", no_wrap=True)
    for path, what, seconds in result.written:
        table.add_row(path.name, what, f"{seconds * 1000:.1f} ms" if seconds else "")
    out.print(table)
    for note in result.notes:
        out.print(note)
    out.print(f"{len(result.written)} files written to {output}/")
    for reason in result.skipped:
        out.print(f"[yellow]skipped[/] {reason}")
