"""The ``--no-reproject`` option of the commands that draw, mesh or export a map, and the
conversion it turns off (:func:`terrascape.io.metric.to_metric`)."""

from __future__ import annotations

import typer

from terrascape.cli.app import console as err
from terrascape.heightmap import Heightmap

NO_REPROJECT = typer.Option(
    False, "--no-reproject",
    help="Keep a map in degrees as it is. By default a map in degrees (a geographic CRS such "
         "as EPSG:4326, or no CRS and a spacing that looks like degrees) is converted to the "
         "UTM zone of its centre (metres), so it is drawn as terrain, not as a needle.")


def metric_map(heightmap: Heightmap, *, no_reproject: bool = False) -> Heightmap:
    """The map converted to metres when it is in degrees, with one line saying so; with
    ``no_reproject`` (or nothing to convert) the map itself, and the warning when its spacing
    still looks like degrees."""
    from terrascape.io.geotiff import degree_warning
    from terrascape.io.metric import to_metric

    if not no_reproject:
        heightmap, message = to_metric(heightmap)
        if message is not None:
            err.print(f"[cyan]note:[/] {message}")
            return heightmap
    warning = degree_warning(heightmap)
    if warning is not None:
        err.print(f"[yellow]warning:[/] {warning}")
    return heightmap


__all__ = ["NO_REPROJECT", "metric_map"]
