"""``terrascape warm-up`` — compile the kernels of the common commands ahead of time."""

from __future__ import annotations

import typer
from rich.markup import escape
from rich.table import Table

from terrascape.cli.app import app, out
from terrascape.warmup import DEFAULT_TASKS, WARM_UP_TASKS


@app.command("warm-up")
def warm_up_command(
    processes: int = typer.Option(
        0, "--processes", "-j",
        help="Processes compiling at once (default: one per CPU)."),
    tasks: str = typer.Option(
        "", "--only",
        help=f"Comma-separated parts of the work: {', '.join(WARM_UP_TASKS)} (default: "
             f"{', '.join(DEFAULT_TASKS)})."),
) -> None:
    """Prepare a new installation: compile the machine code of the common commands once,
    several at a time, so that their first runs start at full speed.

    The first run of a command on a new installation spends most of its time compiling
    (numba); the compiled code is kept on disk for every later run. This runs generate,
    erode, shade, normalmap, render, mesh and the demo's steps on a tiny map, one process
    per CPU, filling that cache in a fraction of the time the first runs would take one
    after another. Running it again only loads the cache.

    The greedy mesher (mesh --mesher greedy) compiles only when asked for with
    --only greedy: the demo does not use it.
    """
    from terrascape.errors import InvalidParameterError
    from terrascape.warmup import check_tasks, warm_up

    chosen = [t.strip() for t in tasks.split(",") if t.strip()] or None
    try:
        check_tasks(chosen or [])
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"--only: {exc}") from None
    if processes < 0:
        raise InvalidParameterError(f"--processes must be >= 0 (0 = one per CPU), got {processes}")
    result = warm_up(chosen, processes or None)
    table = Table(title="numba cache filled", title_justify="left")
    table.add_column("process", justify="right")
    table.add_column("commands")
    table.add_column("time", justify="right")
    for k, share in enumerate(result.shares):
        for name in share:
            table.add_row(str(k + 1), WARM_UP_TASKS[name].summary,
                          f"{result.seconds[name]:.1f} s")
    out.print(table)
    out.print(f"{len(result.shares)} processes, {result.wall:.1f} s in all")
    for reason in result.skipped:
        out.print(f"[yellow]skipped[/] {escape(reason)} (that command compiles on its first run)")
