"""``terrascape info`` and ``terrascape convert`` — heightmap files."""

from __future__ import annotations

import warnings
from pathlib import Path

import typer
from rich.table import Table

from terrascape.cli.app import app, console, out
from terrascape.io.heightmap_file import formats_help

_SIZE_HELP = (
    "Grid size COLSxROWS in samples (or one number for a square), only for headerless "
    "RAW files (.r16/.raw/.r32); default: from the .json sidecar or a square file length."
)
_SPACING_HELP = (
    "Sample spacing in world units, DX or DX,DZ (overrides the file's own); "
    "default: from the file, else 1."
)
_VSCALE_HELP = (
    "Height of full white/65535 in world units for files without units (plain images, "
    "RAW16 without sidecar); a multiplier for files with world units. Default: 1 / unchanged."
)

_CRS_HELP = (
    "Coordinate reference system of the input (EPSG:4326, EPSG:32633 or WKT) when the file "
    "has none or a wrong one; with a geographic CRS the spacing is read as degrees."
)
_REPROJECT_HELP = (
    "Warp to this CRS before writing (e.g. EPSG:32633 for a DEM in degrees); needs rasterio."
)


def _parse_spacing(text: str | None) -> tuple[float, float] | None:
    from terrascape.cli.parsing import parse_floats

    if text is None:
        return None
    parts = text.split(",")
    values = parse_floats(text, len(parts) if len(parts) in (1, 2) else 2, name="--spacing")
    return (values[0], values[0]) if len(values) == 1 else (values[0], values[1])


def _parse_grid(text: str | None) -> tuple[int, int] | None:
    from terrascape.cli.parsing import parse_size

    if text is None:
        return None
    if text.strip().isdigit():
        side = int(text)
        return (side, side)
    return parse_size(text, name="--size")


def _read(path: Path, size: str | None, spacing: str | None, vertical_scale: float | None,
          crs: str | None = None, reproject: str | None = None):
    """Read with warnings shown as one yellow line each (not Python's two-line format);
    then declare ``crs`` and warp to ``reproject`` if given, and warn about degrees."""
    from terrascape.io import read_heightmap
    from terrascape.io.geotiff import assign_crs, degree_warning
    from terrascape.io.geotiff import reproject as warp

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        hm = read_heightmap(
            path,
            size=_parse_grid(size),
            spacing=_parse_spacing(spacing),
            vertical_scale=vertical_scale,
        )
    for w in caught:
        console.print(f"[yellow]warning:[/] {w.message}")
    if crs is not None:
        hm = assign_crs(hm, crs)
    if reproject is not None:
        hm = warp(hm, reproject)
    message = degree_warning(hm)
    if message is not None:
        console.print(f"[yellow]warning:[/] {message}")
    return hm


@app.command(help=f"Describe a heightmap file. Reads: {formats_help()}.")
def info(
    file: Path = typer.Argument(..., help="Heightmap file to describe."),
    size: str = typer.Option(None, "--size", help=_SIZE_HELP, show_default="from file"),
    spacing: str = typer.Option(None, "--spacing", help=_SPACING_HELP, show_default="from file"),
    vertical_scale: float = typer.Option(
        None, "--vertical-scale", help=_VSCALE_HELP, show_default="1 / unchanged"
    ),
    crs: str = typer.Option(None, "--crs", help=_CRS_HELP, show_default="from file"),
) -> None:
    """Print size, value range, on-disk dtype, spacing, extent and NaN-filled count."""
    hm = _read(file, size, spacing, vertical_scale, crs)
    md = hm.metadata
    table = Table(title=str(file), show_header=False)
    table.add_column("property")
    table.add_column("value")
    table.add_row("format", str(md.get("format")))
    table.add_row("size", f"{hm.cols}×{hm.rows} (cols×rows)")
    table.add_row("dtype on disk", str(md.get("dtype")))
    table.add_row("height range", f"{hm.min:.6g} … {hm.max:.6g} (world units)")
    step = float(md.get("step", 0.0))
    table.add_row("quantisation step", f"{step:.6g}" if step else "exact (no quantisation)")
    if "units_restored" in md:
        table.add_row(
            "world units",
            "restored from metadata" if md["units_restored"] else "normalised × vertical scale",
        )
    table.add_row("spacing", f"dx={hm.spacing[0]:.6g}, dz={hm.spacing[1]:.6g}")
    table.add_row("extent", f"{hm.extent[0]:.6g} × {hm.extent[1]:.6g} (x × z)")
    table.add_row("NaN/nodata filled", str(md.get("filled", 0)))
    if md.get("geographic"):
        table.add_row("georeference", "geographic (degrees → metres at centre latitude)")
    if hm.crs is not None:
        crs_text = hm.crs if len(hm.crs) <= 60 else hm.crs[:57] + "…"
        table.add_row("CRS", crs_text)
        table.add_row("origin", f"x={hm.origin[0]:.10g}, y={hm.origin[1]:.10g} (corner of "
                      "the first sample)")
    if hm.nodata is not None:
        table.add_row("nodata value", f"{hm.nodata:.10g}")
    out.print(table)


@app.command(
    help=f"Convert a heightmap between formats by extension. Writes: {formats_help(write=True)}."
)
def convert(
    source: Path = typer.Argument(..., help=f"Input heightmap ({formats_help()})."),
    target: Path = typer.Argument(..., help=f"Output file ({formats_help(write=True)})."),
    size: str = typer.Option(None, "--size", help=_SIZE_HELP, show_default="from file"),
    spacing: str = typer.Option(None, "--spacing", help=_SPACING_HELP, show_default="from file"),
    vertical_scale: float = typer.Option(
        None, "--vertical-scale", help=_VSCALE_HELP, show_default="1 / unchanged"
    ),
    crs: str = typer.Option(None, "--crs", help=_CRS_HELP, show_default="from file"),
    reproject: str = typer.Option(None, "--reproject", help=_REPROJECT_HELP,
                                  show_default="off"),
    cog: bool = typer.Option(
        False, "--cog",
        help="TARGET .tif as a Cloud-Optimized GeoTIFF (tiled, overviews, for web map servers)."),
    force: bool = typer.Option(False, "--force", help="Overwrite TARGET (and its sidecar)."),
) -> None:
    """Read SOURCE and write it as TARGET (format chosen by TARGET's extension)."""
    from terrascape.io import check_output_path, write_heightmap

    if cog and target.suffix.lower() not in (".tif", ".tiff"):
        from terrascape.errors import InvalidParameterError

        raise InvalidParameterError(f"--cog writes a .tif file, got {target.name!r}")
    check_output_path(target, force=force)  # fail before reading a large input
    hm = _read(source, size, spacing, vertical_scale, crs, reproject)
    from terrascape.io.heightmap_file import WRITE_METADATA

    written = write_heightmap(hm, target, force=force, format="cog" if cog else None)
    keeps = WRITE_METADATA.get(target.suffix.lower().lstrip("."))
    heights = f"heights {hm.min:.6g} … {hm.max:.6g}"
    spacing = f"spacing ({hm.spacing[0]:.6g}, {hm.spacing[1]:.6g})"
    if keeps is not None and not keeps.world_units:
        heights = f"heights {hm.min:.6g} … {hm.max:.6g} stored as 0 … 1"
    if keeps is not None and not keeps.spacing:
        spacing = f"{spacing} not stored"
    out.print(f"{source} → {written}: {hm.cols}×{hm.rows}, {heights}, {spacing}")
