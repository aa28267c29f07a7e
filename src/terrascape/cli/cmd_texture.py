"""``terrascape texture …`` — region textures, splat maps and built-in materials (MISSION T1–T3)."""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np
import typer

from terrascape.cli.app import app, console, progress
from terrascape.errors import FileFormatError

texture_app = typer.Typer(
    help="Texture synthesis: height-region textures, splat maps, built-in materials.",
    no_args_is_help=True,
)
app.add_typer(texture_app, name="texture")

_HM_HELP = "Heightmap file (any format `terrascape info` reads)."


def _read_heightmap(path: Path):
    from terrascape.io import read_heightmap

    return read_heightmap(path)


def _read_lightmap(path: Path) -> np.ndarray:
    """A grey image as floats in [0, 1] (8- or 16-bit; colour → luminance)."""
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise FileFormatError(f"lightmap file {path} does not exist")
    try:
        with Image.open(path) as img:
            if img.mode in ("I;16", "I;16B", "I;16L", "I"):
                return np.clip(np.asarray(img, dtype=np.float64) / 65535.0, 0.0, 1.0)
            if img.mode == "F":
                return np.clip(np.asarray(img, dtype=np.float64), 0.0, 1.0)
            return np.asarray(img.convert("L"), dtype=np.float64) / 255.0
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(f"{path} is not a readable image file ({exc})") from None


def _read_material_ids(path: Path) -> np.ndarray:
    """Per-cell material ids from an integer .npy or an 8-bit grey/palette image."""
    from PIL import Image, UnidentifiedImageError

    if not path.is_file():
        raise FileFormatError(f"material map {path} does not exist")
    if path.suffix.lower() == ".npy":
        try:
            ids = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{path} is not a readable .npy file ({exc})") from None
        return ids
    try:
        with Image.open(path) as img:
            if img.mode not in ("L", "P"):
                raise FileFormatError(
                    f"material map {path} must be an 8-bit grey or palette image (value = id), "
                    f"got mode {img.mode}"
                )
            return np.asarray(img).astype(np.int64)
    except (UnidentifiedImageError, OSError) as exc:
        raise FileFormatError(f"{path} is not a readable image file ({exc})") from None


def _image_format(final: Path) -> str:
    fmt = {".png": "PNG", ".bmp": "BMP", ".tif": "TIFF", ".tiff": "TIFF", ".jpg": "JPEG",
           ".jpeg": "JPEG"}.get(final.suffix.lower())
    if fmt is None:
        raise FileFormatError(
            f"output {final} must end in .png, .bmp, .tif/.tiff or .jpg, got {final.suffix!r}"
        )
    return fmt


def _save_rgb(image: np.ndarray, tmp: Path, final: Path) -> None:
    from PIL import Image

    fmt = _image_format(final)
    mode = "RGBA" if image.shape[-1] == 4 else "RGB"
    Image.fromarray(image, mode).save(tmp, format=fmt)


@texture_app.command("regions")
def regions_cmd(
    heightmap: Path = typer.Argument(..., help=_HM_HELP),
    output: Path = typer.Option(..., "--output", "-o", help="Output image (.png/.bmp/.tif/.jpg)."),
    scale: int = typer.Option(1, "--scale", min=1, max=64,
                              help="Output texels per heightmap sample along each axis (integer)."),
    jitter: float = typer.Option(0.0, "--jitter", min=0.0, max=1.0,
                                 help="Band-limit jitter as a fraction of each band's range "
                                      "(never water)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed for jitter and built-in materials."),
    slope_rule: bool = typer.Option(True, "--slope-rule/--no-slope-rule",
                                    help="Rock on slopes steeper than 30°, fully from 45°."),
    lightmap: Path = typer.Option(None, "--lightmap",
                                  help="Grey image in [0, 1] (white = lit) multiplied in; any "
                                       "size, resampled.", show_default="none"),
    texture_size: int = typer.Option(256, "--texture-size", min=4, max=8192,
                                     help="Side of each material texture in pixels."),
    tile_size: float = typer.Option(None, "--tile-size",
                                    help="World units per material texture repeat.",
                                    show_default="32 × sample spacing"),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output."),
) -> None:
    """Procedural colour texture from height bands (seed 001 §3.1.1), with slope and jitter."""
    from terrascape.io import atomic_output, check_output_path
    from terrascape.texture import region_texture

    check_output_path(output, force=force)  # fail before the work, not after
    _image_format(output)
    with progress(quiet=quiet) as bar:
        task = bar.add_task("texture regions", total=3)
        hm = _read_heightmap(heightmap)
        light = _read_lightmap(lightmap) if lightmap is not None else None
        bar.advance(task)
        tex = region_texture(hm, scale=scale, jitter=jitter, seed=seed, slope_rule=slope_rule,
                             lightmap=light, texture_size=texture_size, tile_size=tile_size)
        bar.advance(task)
        with atomic_output(output, force=force) as tmp:
            _save_rgb(tex, tmp, output)
        bar.advance(task)
    if not quiet:
        console.print(f"wrote {output} ({tex.shape[1]}×{tex.shape[0]} RGB)")


@texture_app.command("splat")
def splat_cmd(
    heightmap: Path = typer.Argument(..., help=_HM_HELP),
    output: str = typer.Option(..., "--output", "-o",
                               help="Output prefix: writes PREFIX_0.png, PREFIX_1.png, … "
                                    "(4 layers per RGBA image)."),
    block: int = typer.Option(32, "--block", min=1,
                              help="Block side in cells for the block-wise computation."),
    materials: Path = typer.Option(None, "--materials",
                                   help="Per-cell material ids, (cols-1)×(rows-1): 8-bit grey or "
                                        "palette PNG (value = id) or integer .npy.",
                                   show_default="from height/slope rules"),
    layers: int = typer.Option(None, "--layers", min=1, max=256,
                               help="Number of layers with --materials.",
                               show_default="max id + 1"),
    slope_rule: bool = typer.Option(True, "--slope-rule/--no-slope-rule",
                                    help="Rock material on cells steeper than 30°/45°."),
    force: bool = typer.Option(False, "--force", help="Overwrite existing output files."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output."),
) -> None:
    """Splat alpha maps (seed 001 §3.1.3) at vertex resolution, packed 4 layers per RGBA PNG.

    Without --materials, layers are the default regions: 0 water, 1 sand, 2 grass, 3 rock,
    4 snow. Either every file is written or none is.
    """
    from terrascape.io import atomic_output, check_output_path
    from terrascape.texture import (
        check_material_map,
        default_regions,
        material_ids_from_rules,
        pack_splat_maps,
        splat_weights,
    )

    with progress(quiet=quiet) as bar:
        task = bar.add_task("splat maps", total=4)
        hm = _read_heightmap(heightmap)
        if materials is not None:
            ids = _read_material_ids(materials)
            check_material_map(hm, ids)
            n_layers = layers if layers is not None else int(ids.max()) + 1
            names = [f"{k}" for k in range(n_layers)]
        else:
            regions = default_regions(hm)
            n_layers = len(regions)
            names = [f"{k}={r.name}" for k, r in enumerate(regions)]
        n_images = (n_layers + 3) // 4
        # "-o splat.png" and "-o splat" both give splat_0.png, splat_1.png, ...
        base = Path(output)
        base = base.with_suffix("") if base.suffix.lower() == ".png" else base
        paths = [Path(f"{base}_{k}.png") for k in range(n_images)]
        for p in paths:  # all-or-nothing: refuse before writing any
            check_output_path(p, force=force)
        bar.advance(task)
        if materials is None:
            ids = material_ids_from_rules(hm, regions, slope_rule=slope_rule)
        bar.advance(task)
        images = pack_splat_maps(splat_weights(ids, n_layers, block=block))
        bar.advance(task)
        # Every file goes to a temporary first; the renames happen only after all writes
        # succeeded, so a failure leaves no new file behind.
        with contextlib.ExitStack() as stack:
            for img, p in zip(images, paths, strict=True):
                tmp = stack.enter_context(atomic_output(p, force=force))
                _save_rgb(img, tmp, p)
        bar.advance(task)
    if not quiet:
        console.print(f"wrote {', '.join(map(str, paths))} (layers {', '.join(names)})")


def _read_mask(path: Path | None, name: str) -> np.ndarray | None:
    """A float mask from .npy, or from a grey image (values / full scale, in [0, 1])."""
    if path is None:
        return None
    if path.suffix.lower() == ".npy":
        if not path.is_file():
            raise FileFormatError(f"{name} mask {path} does not exist")
        try:
            return np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise FileFormatError(f"{path} is not a readable .npy file ({exc})") from None
    return _read_lightmap(path).astype(np.float32)


@texture_app.command("material")
def material_cmd(
    name: str = typer.Argument(
        ..., help="A heightmap file: the terrain's default material as a top-down image; or "
                  "a material name: water, sand, grass, rock, snow (procedural) or "
                  "photo-grass, photo-meadow, photo-rock, photo-scree, photo-sediment, "
                  "photo-snow, photo-water (from photographs)."),
    output: Path = typer.Option(..., "--output", "-o", help="Output image (.png/.bmp/.tif/.jpg)."),
    size: int = typer.Option(256, "--size", min=4, max=8192,
                             help="Side in pixels of a single material (photo: a power of two)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Noise seed."),
    scale: int = typer.Option(1, "--scale", min=1, max=64,
                              help="Terrain: output texels per heightmap sample."),
    flow: Path = typer.Option(None, "--flow", help="Terrain: flow mask (.npy float or grey "
                              "image, heightmap size): sediment in channels.",
                              show_default="none"),
    deposition: Path = typer.Option(None, "--deposition", help="Terrain: deposition mask.",
                                    show_default="none"),
    wear: Path = typer.Option(None, "--wear", help="Terrain: wear mask in [0, 1] (bare ground).",
                              show_default="none"),
    water: Path = typer.Option(None, "--water", help="Terrain: water mask in [0, 1].",
                               show_default="none"),
    snow_line: float = typer.Option(None, "--snow-line", help="Terrain: snow only above this "
                                    "height (world units).", show_default="78 % of the range"),
    water_level: float = typer.Option(None, "--water-level", help="Terrain: water at and "
                                      "below this height.", show_default="none"),
    lightmap: Path = typer.Option(None, "--lightmap", help="Terrain: grey image in [0, 1] "
                                  "multiplied in.", show_default="none"),
    tile_size: float = typer.Option(None, "--tile-size", help="Terrain: world units per "
                                    "material repeat.", show_default="32 × sample spacing"),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing output file."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress output."),
) -> None:
    """Write a material texture: one tiling material, or a terrain's default material.

    For a terrain, rock covers cliffs, scree lies under them, grass and meadow the flats,
    sediment the channels (with --flow/--deposition), snow the high flats; every layer is a
    photo texture hex-tiled so no repeat shows.
    """
    from terrascape.io import atomic_output, check_output_path
    from terrascape.texture import builtin_material
    from terrascape.texture.materials import BUILTIN_MATERIALS
    from terrascape.texture.photo_materials import MATERIAL_LAYERS, photo_material

    check_output_path(output, force=force)
    _image_format(output)
    key = name.lower()
    if key in BUILTIN_MATERIALS:
        img = builtin_material(key, size, seed=seed)
    elif key.startswith("photo-") and key[6:] in MATERIAL_LAYERS:
        img = photo_material(key[6:], size, seed=seed)
    else:
        from terrascape.texture.terrain_material import MaterialRules, material_texture

        path = Path(name)
        if not path.is_file():
            raise FileFormatError(
                f"{name!r} is neither a heightmap file nor a material name "
                f"({', '.join(BUILTIN_MATERIALS)}, photo-<{'|'.join(MATERIAL_LAYERS)}>)"
            )
        with progress(quiet=quiet) as bar:
            task = bar.add_task("texture material", total=3)
            hm = _read_heightmap(path)
            masks = {k: m for k, m in (("flow", _read_mask(flow, "flow")),
                                       ("deposition", _read_mask(deposition, "deposition")),
                                       ("wear", _read_mask(wear, "wear")),
                                       ("water", _read_mask(water, "water"))) if m is not None}
            light = _read_lightmap(lightmap) if lightmap is not None else None
            bar.advance(task)
            rules = MaterialRules(snow_line=snow_line, water_level=water_level)
            img = material_texture(hm, masks=masks, rules=rules, scale=scale, seed=seed,
                                   tile_size=tile_size, lightmap=light)
            bar.advance(task)
            with atomic_output(output, force=force) as tmp:
                _save_rgb(img, tmp, output)
            bar.advance(task)
        if not quiet:
            console.print(f"wrote {output} ({img.shape[1]}×{img.shape[0]} RGB)")
        return
    with atomic_output(output, force=force) as tmp:
        _save_rgb(img, tmp, output)
