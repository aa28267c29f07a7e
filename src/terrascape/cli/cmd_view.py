"""``terrascape view``: the interactive viewer window."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from terrascape._validate import check_int, check_positive
from terrascape.cli.app import MAX_MEMORY, app, console, timed, use_max_memory
from terrascape.cli.cmd_render import (
    OBJECT_SHADOWS_HELP,
    OBJECTS_HELP,
    check_object_shadows,
    load_objects_option,
)
from terrascape.cli.geo_options import NO_REPROJECT, metric_map
from terrascape.cli.parsing import is_world_store
from terrascape.errors import InvalidParameterError
from terrascape.generate.registry import VIEW_SPACING, generator_names, get_generator, names_help
from terrascape.lod.schemes import SCHEMES
from terrascape.viewer.resolution import DEFAULT_TARGET_FPS

LOD_CHOICES = ("none", *SCHEMES)


def generate_terrain(kind: str, size: int, seed: int, *, spacing: float = VIEW_SPACING,
                     params: dict | None = None):
    """The registry's terrain ``kind`` (:func:`terrascape.generate.registry.generate`) with
    its defaults: heights span ``[0, 0.2 · extent]`` (a 257-sample map on a 2 m grid: 512 m
    across, up to ~100 m high), so every size looks alike from the start camera."""
    from terrascape.generate.registry import generate

    size = check_int(size, "--gen-size", minimum=3, maximum=8193)
    return generate(kind, size, seed=seed, spacing=spacing, **(params or {}))


def _is_world(path: Path) -> bool:
    return is_world_store(path)


@app.command("view")
def view_cmd(
    heightmap: Path = typer.Argument(
        None, help="Heightmap file (.png/.bmp/.jpg, .r16/.raw/.r32, .tif, .npy, .ter) or a "
        "world store (world.zarr: streamed by tiles, each at the level the view needs, within "
        "--max-memory).",
        show_default="none: use --generate"),
    generate: str = typer.Option(
        None, "--generate", help=f"Generate the terrain instead: {names_help()}.",
        show_default="none"),
    gen_param: list[str] = typer.Option(
        None, "--gen-param", help="A generator parameter NAME=VALUE, repeatable (e.g. "
        "octaves=8); the names are the options of `terrascape generate NAME`.",
        show_default="the generator's defaults"),
    gen_size: int = typer.Option(
        257, "--gen-size", help="Samples per side of a generated terrain (2^n+1 for "
        "diamond-square)."),
    seed: int = typer.Option(0, "--seed", help="Random seed of the generator."),
    spacing: float = typer.Option(
        None, "--spacing", help="Sample spacing in world units (metres); default: the file's, "
        "2 m for generated terrains.", show_default="file / 2"),
    vertical_scale: float = typer.Option(
        None, "--vertical-scale", help="World height of the full-scale value for formats "
        "without height units (plain images), in metres.", show_default="reader default"),
    texture: Path = typer.Option(
        None, "--texture", help="Colour image stretched over the whole terrain.",
        show_default="procedural region texture"),
    technique: str = typer.Option(
        None, "--technique", show_default="material (plain with --texture)",
        help="Start technique (Tab switches at run time): {techniques}."),
    lod: str = typer.Option(
        "none", "--lod",
        help=f"Level of detail: {', '.join(LOD_CHOICES)} (L switches, J picks the setting "
        "PgUp/PgDn change)."),
    size: str = typer.Option("1280x720", "--size", help="Window size WIDTHxHEIGHT in pixels."),
    fullscreen: bool = typer.Option(False, "--fullscreen", help="Open full screen."),
    exaggeration: float = typer.Option(1.0, "--exaggeration", help="Vertical scale factor."),
    sea_level: float = typer.Option(
        None, "--sea-level", help="Water surface height (world units), with animated ripples.",
        show_default="no water"),
    pad: bool = typer.Option(
        False, "--pad", help="Pad the heightmap to a square 2^n+1 grid (needed by the LOD "
        "algorithms) by repeating edge samples."),
    screenshot_dir: Path = typer.Option(
        None, "--screenshot-dir", help="Folder for F12 screenshots (PNG).",
        show_default="Pictures/terrascape, else screenshots/ next to the file"),
    frames: int = typer.Option(
        0, "--frames", help="Quit after this many frames (0: run until Esc).", min=0),
    no_hud: bool = typer.Option(False, "--no-hud", help="Hide the on-screen text."),
    target_fps: float = typer.Option(
        DEFAULT_TARGET_FPS, "--target-fps", min=0.0, max=1000.0,
        help="Frame rate held while flying: frames are drawn smaller and enlarged when the "
        "look is too heavy for it, and at full size once the camera stops. 0: always full "
        "size."),
    time: str = typer.Option(
        None, "--time",
        help="Start the sky clock at this date and time (e.g. 2026-06-21T05:00), running: "
        "sun, moon and stars move (Space pauses, R reverses, C/V speed). Without a UTC "
        "offset local solar time; with one civil time (needs --longitude or a georeferenced "
        "map).",
        show_default=False),
    latitude: float = typer.Option(
        None, "--latitude", help="Latitude (degrees north) of the sky clock. [default: the "
        "map's georeference, else 45]", show_default=False),
    longitude: float = typer.Option(
        None, "--longitude", help="Longitude (degrees east) of the sky clock. [default: the "
        "map's georeference]", show_default=False),
    objects: str = typer.Option(None, "--objects", help=OBJECTS_HELP + " B shows/hides them.",
                                show_default=False),
    object_shadows: str = typer.Option(
        None, "--object-shadows", help=OBJECT_SHADOWS_HELP + " G cycles them.",
        show_default=False),
    no_reproject: bool = NO_REPROJECT,
    max_memory: str = MAX_MEMORY,
) -> None:
    """Fly over a terrain in a window: mouse look (click; Esc releases, Esc again quits),
    W A S D / arrows, Q/E down/up, Shift faster, scroll for speed; F1 or H lists every key.

    Needs a display; for headless use render images with `terrascape render`.
    """
    from terrascape.cli.parsing import parse_size
    from terrascape.render.techniques import technique_names
    from terrascape.viewer.app import check_display, run_viewer

    use_max_memory(max_memory)
    # Cheap checks first, so a wrong option never waits for a terrain to be generated.
    if (heightmap is None) == (generate is None):
        raise InvalidParameterError(
            f"give either a HEIGHTMAP file or --generate {'|'.join(generator_names())} "
            "(not both)")
    gen_params: dict = {}
    if generate is not None:
        from terrascape.generate.registry import parse_params

        get_generator(generate)
        gen_params = parse_params(generate, gen_param)
    if technique is None:
        # --texture replaces the colour texture the plain family samples; material has none.
        technique = "plain" if texture is not None else "material"
    from terrascape.render.techniques import canonical_technique_name

    technique = canonical_technique_name(technique)  # old spellings, with a note
    names = technique_names()
    if technique not in names:
        raise InvalidParameterError(
            f"--technique must be one of {', '.join(names)}, got {technique!r}")
    if lod not in LOD_CHOICES:
        raise InvalidParameterError(f"--lod must be one of {', '.join(LOD_CHOICES)}, got {lod!r}")
    width, height = parse_size(size, name="--size")
    check_positive(exaggeration, "--exaggeration")
    if not math.isfinite(exaggeration):
        raise InvalidParameterError(f"--exaggeration must be finite, got {exaggeration}")
    if screenshot_dir is not None and not screenshot_dir.is_dir():
        raise InvalidParameterError(f"--screenshot-dir {screenshot_dir} is not a folder")
    if sea_level is not None and not math.isfinite(sea_level):
        raise InvalidParameterError(f"--sea-level must be finite, got {sea_level}")
    if time is None and (latitude is not None or longitude is not None):
        raise InvalidParameterError("--latitude/--longitude place the sky clock of --time; "
                                    "give --time")
    if time is not None:
        from terrascape.lighting.solar_position import check_latitude, parse_time

        parse_time(time)
        if latitude is not None:
            check_latitude(latitude)
    check_object_shadows(object_shadows)
    if object_shadows is not None and objects is None:
        raise InvalidParameterError("--object-shadows needs --objects")
    check_display()

    world = None
    if generate is not None:
        with timed(f"generate {generate} {gen_size}×{gen_size}"):
            hm = generate_terrain(generate, gen_size, seed, params=gen_params,
                                  spacing=VIEW_SPACING if spacing is None else check_positive(
                                      spacing, "--spacing"))
    elif _is_world(heightmap):
        from terrascape.memory import format_bytes, memory_limit
        from terrascape.render.tiled_terrain import split_budget
        from terrascape.world.chunked_lod import world_pyramid

        with timed(f"read world {heightmap.name}"):
            win, share = split_budget(heightmap, memory_limit())
            pyramid = world_pyramid(heightmap)  # the tiles' error table, once per world
        hm = win.heightmap
        world = (heightmap, share, pyramid)
        console.print(f"[dim]world at level {win.level} (spacing × {1 << win.level}): "
                      f"{hm.cols}×{hm.rows}; tiles of levels 0–{pyramid.grid.top} stream in "
                      f"within {format_bytes(share.tile_bytes)}[/]")
    else:
        from terrascape.io import read_heightmap

        with timed(f"read {heightmap.name}"):
            hm = read_heightmap(heightmap, spacing=spacing, vertical_scale=vertical_scale)
        hm = metric_map(hm, no_reproject=no_reproject)
    if pad and world is None and not hm.is_pow2_plus1:
        hm = hm.to_pow2_plus1("pad")
        console.print(f"[dim]padded to {hm.cols}×{hm.rows} for LOD[/]")
    if sea_level is not None:
        from terrascape.render.atmosphere import sea_level_note

        note = sea_level_note(hm, sea_level)
        if note:
            console.print(f"[yellow]warning:[/yellow] {note}")
    instances = None
    if objects is not None:
        with timed("objects"):
            instances = load_objects_option(objects, hm, seed=seed, exaggeration=exaggeration)
    tex = None
    if texture is not None:
        from terrascape.texture.materials import read_image_rgb

        tex = read_image_rgb(texture)
    sky_clock = None
    if time is not None:
        from terrascape.lighting.sky_time import resolve_place, start_instant

        place = resolve_place(hm, latitude, longitude)
        utc, lon = start_instant(time, place)
        sky_clock = (utc, place.latitude, lon)
    frames_drawn = run_viewer(hm, size=(width, height), fullscreen=fullscreen,
                              technique=technique, lod=lod, texture=tex,
                              exaggeration=exaggeration, screenshot_dir=screenshot_dir,
                              max_frames=frames, hud=not no_hud, sea_level=sea_level,
                              sky_clock=sky_clock, objects=instances,
                              object_shadows=object_shadows, world=world,
                              target_fps=target_fps)
    console.print(f"[dim]viewer closed after {frames_drawn} frames[/]")
