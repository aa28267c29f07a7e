"""``terrascape texture …`` — region textures, splat maps and built-in materials."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from terrascape.cli.app import MAX_MEMORY, app, console, progress, use_max_memory
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


def _check_memory(command: str, rows: int, cols: int, max_memory: str | None, hint: str,
                  extra: float = 0.0) -> None:
    from terrascape.memory import check_grid

    use_max_memory(max_memory)
    check_grid(command, rows, cols, hint=hint, extra=extra)


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
    max_memory: str = MAX_MEMORY,
) -> None:
    """Procedural colour texture from height bands, with rock on slopes and jitter."""
    from terrascape.io import atomic_output, check_output_path
    from terrascape.texture import region_texture

    check_output_path(output, force=force)  # fail before the work, not after
    _image_format(output)
    with progress(quiet=quiet) as bar:
        task = bar.add_task("texture regions", total=3)
        hm = _read_heightmap(heightmap)
        _check_memory("texture regions", hm.rows * scale, hm.cols * scale,
                      max_memory, "use a smaller --scale or map (or raise --max-memory)")
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


#: Preview colours of the default layers (by region name) and of numbered layers.
_LAYER_COLOURS = {
    "water": (40, 90, 170), "sand": (205, 185, 130), "grass": (70, 135, 50),
    "rock": (120, 110, 100), "snow": (245, 245, 250),
}


def layer_colour(k: int, name: str | None = None) -> tuple[int, int, int]:
    """A distinct opaque colour for splat layer ``k`` (its material's when named)."""
    import colorsys

    if name in _LAYER_COLOURS:
        return _LAYER_COLOURS[name]
    hue = (k * 0.618033988749895) % 1.0  # golden-angle steps: neighbours never look alike
    r, g, b = colorsys.hsv_to_rgb(hue, 0.65, 0.9)
    return round(r * 255), round(g * 255), round(b * 255)


def splat_rgb_images(packed: list[np.ndarray], n_layers: int) -> list[np.ndarray]:
    """The quantised weights of :func:`~terrascape.texture.pack_splat_maps` (4 layers per
    RGBA image) as opaque RGB images, 3 layers per image: layer ``k`` in image ``k // 3``,
    channel ``k % 3``. Same codes (each vertex's still sum to 255); nothing sits in an alpha
    channel, which viewers show as transparency."""
    channels = np.concatenate(packed, axis=-1)[..., :n_layers]
    pad = (-n_layers) % 3
    if pad:
        channels = np.concatenate(
            [channels, np.zeros((*channels.shape[:2], pad), np.uint8)], axis=-1)
    return [np.ascontiguousarray(channels[..., i:i + 3]) for i in range(0, channels.shape[-1], 3)]


def splat_preview(weights: np.ndarray, colours: list[tuple[int, int, int]]) -> np.ndarray:
    """Opaque RGB composite: every vertex's layer colours mixed by its weights."""
    palette = np.asarray(colours, dtype=np.float32)  # (L, 3)
    rgb = np.tensordot(np.asarray(weights, np.float32), palette, axes=(0, 0))
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


@texture_app.command("splat")
def splat_cmd(
    heightmap: Path = typer.Argument(..., help=_HM_HELP),
    output: str = typer.Option(..., "--output", "-o",
                               help="Output prefix: writes PREFIX_0.png, PREFIX_1.png, … "
                                    "(3 layer weights per opaque RGB image) and "
                                    "PREFIX_preview.png (layer colours mixed by weight)."),
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
    """Splat maps: per-layer blend weights at vertex resolution, 3 layers per RGB PNG
    (0…255, each vertex's weights sum to 255), plus a colour preview of the blend.

    Without --materials, layers are the default regions: 0 water, 1 sand, 2 grass, 3 rock,
    4 snow. Either every file is written or none is.
    """
    from terrascape.io import check_output_path
    from terrascape.io.atomic import atomic_outputs
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
            layer_names: list[str | None] = [None] * n_layers
            names = [f"{k}" for k in range(n_layers)]
        else:
            regions = default_regions(hm)
            n_layers = len(regions)
            layer_names = [r.name for r in regions]
            names = [f"{k}={r.name}" for k, r in enumerate(regions)]
        n_images = (n_layers + 2) // 3
        # "-o splat.png" and "-o splat" both give splat_0.png, splat_1.png, ...
        base = Path(output)
        base = base.with_suffix("") if base.suffix.lower() == ".png" else base
        paths = [Path(f"{base}_{k}.png") for k in range(n_images)]
        preview_path = Path(f"{base}_preview.png")
        for p in (*paths, preview_path):  # all-or-nothing: refuse before writing any
            check_output_path(p, force=force)
        bar.advance(task)
        if materials is None:
            ids = material_ids_from_rules(hm, regions, slope_rule=slope_rule)
        bar.advance(task)
        weights = splat_weights(ids, n_layers, block=block)
        images = splat_rgb_images(pack_splat_maps(weights), n_layers)
        preview = splat_preview(
            weights, [layer_colour(k, name) for k, name in enumerate(layer_names)])
        bar.advance(task)
        # One unit: every file goes to a temporary first and all are committed together
        # (rolled back if any rename fails), so a reader sees all new maps or none.
        outputs = [*paths, preview_path]
        with atomic_outputs(outputs, force=force) as tmps:
            for img, tmp, p in zip((*images, preview), tmps, outputs, strict=True):
                _save_rgb(img, tmp, p)
        bar.advance(task)
    if not quiet:
        console.print(f"wrote {', '.join(map(str, paths))} (layers {', '.join(names)}, "
                      f"3 per image in R, G, B) and the preview {preview_path}")


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
    max_memory: str = MAX_MEMORY,
) -> None:
    """Write a material texture: one tiling material, or a terrain's default material.

    For a terrain, rock covers cliffs, scree lies under them, grass and meadow the flats,
    sediment the channels (with --flow/--deposition), snow the high flats; every layer is a
    photo texture hex-tiled so no repeat shows.
    """
    from terrascape.io import atomic_output, check_output_path
    from terrascape.texture import builtin_material
    from terrascape.texture.materials import BUILTIN_MATERIALS
    from terrascape.texture.photo_materials import (
        MATERIAL_LAYERS,
        layer_spectrum_bytes,
        photo_material,
    )

    check_output_path(output, force=force)
    _image_format(output)
    key = name.lower()
    if key in BUILTIN_MATERIALS or key.startswith("photo-"):
        photo = key.startswith("photo-")
        _check_memory("texture photo" if photo else "texture material", size, size, max_memory,
                      "use a smaller --size (or raise --max-memory)",
                      extra=layer_spectrum_bytes(size) if photo else 0.0)
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
            _check_memory("texture material", hm.rows * scale, hm.cols * scale, max_memory,
                          "use a smaller --scale (or raise --max-memory)")
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
