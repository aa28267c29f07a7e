"""``terrascape mesh`` — export a terrain mesh (OBJ / PLY / GLB) at a measured error.

Three modes:

* ``--max-error METRES`` and/or ``--triangles N``: a static mesh with a true maximum
  vertical error / a hard triangle budget, by any mesher of
  :data:`terrascape.lod.static_meshers.STATIC_MESHERS` (``--mesher``; RTIN by default);
* ``--camera X,Y,Z --target X,Y,Z``: the view-dependent mesh a renderer would draw from that
  camera, by any scheme of :data:`terrascape.lod.schemes.SCHEMES` (``--lod``; geomipmapping
  by default), with ``--tolerance PIXELS`` and/or ``--triangles N`` as the scheme takes them.

The printed error is always MEASURED on every grid sample (vertical error in world units;
screen-space pixels for the view-dependent mode), never the requested value.
"""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.camera import Camera
from terrascape.cli.app import app, max_memory_option, out, timed, use_max_memory
from terrascape.cli.geo_options import NO_REPROJECT, metric_map
from terrascape.cli.parsing import parse_floats, parse_size
from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError
from terrascape.lod.schemes import SCHEMES
from terrascape.lod.static_meshers import DEFAULT_STATIC_MESHER, STATIC_MESHERS
from terrascape.memory import check_grid, check_triangles

_FITS = ("none", "pad", "resample")
_DEFAULT_TOLERANCE = 2.0
# update() keyword → the option that gives it
_FLAGS = {"tolerance_px": "--tolerance", "max_triangles": "--triangles"}
# the static meshers --one-piece applies to (in_pieces=False)
_ONE_PIECE_MESHERS = tuple(n for n, m in STATIC_MESHERS.items() if "in_pieces" in m.options)


def _read(path: Path, spacing: str | None, vertical_scale: float | None):
    from terrascape.io import read_heightmap

    sp = None
    if spacing is not None:
        parts = spacing.split(",")
        sp = parse_floats(spacing, 2 if len(parts) == 2 else 1, name="--spacing")
        sp = (sp[0], sp[-1])
    try:
        return read_heightmap(path, spacing=sp, vertical_scale=vertical_scale)
    except TerrascapeError:
        raise
    except (OSError, ValueError) as exc:
        raise FileFormatError(f"cannot read heightmap {path}: {exc}") from exc


@app.command("mesh")
def mesh_command(
    heightmap: Path = typer.Argument(..., help="Heightmap file (any format `info` reads)."),
    output: Path = typer.Option(
        ..., "--output", "-o", help="Output mesh: .obj, .ply (binary) or .glb (glTF 2.0)."
    ),
    max_error: float = typer.Option(
        None, "--max-error", help="Static mesh: largest vertical error in world units (metres).",
        show_default="off",
    ),
    triangles: int = typer.Option(
        None, "--triangles", help="Hard triangle budget (never exceeded): the static mesh's, "
        "or the view-dependent scheme's (" + ", ".join(
            n for n, s in SCHEMES.items() if "max_triangles" in s.parameter_names) + ").",
        show_default="off",
    ),
    camera: str = typer.Option(
        None, "--camera", help="View-dependent mesh: camera position X,Y,Z in world units.",
        show_default="off",
    ),
    target: str = typer.Option(
        None, "--target", help="View-dependent mesh: point looked at, X,Y,Z in world units.",
        show_default="off",
    ),
    tolerance: float = typer.Option(
        None, "--tolerance", help="View-dependent mesh: screen-space error tolerance τ (pixels; "
        + ", ".join(n for n, s in SCHEMES.items() if "tolerance_px" in s.parameter_names)
        + ").", show_default=f"{_DEFAULT_TOLERANCE:g}",
    ),
    lod: str = typer.Option(
        "geomipmap", "--lod", help="View-dependent scheme: " + "; ".join(
            f"{n} ({s.help})" for n, s in SCHEMES.items()) + ".",
    ),
    size: str = typer.Option(
        "1920x1080", "--size", help="View-dependent mesh: viewport WIDTHxHEIGHT (pixels)."
    ),
    fov: float = typer.Option(60.0, "--fov", help="Vertical field of view (degrees)."),
    patch_size: int = typer.Option(
        None, "--patch-size", help="Patch size in samples (2**k + 1) of the patch schemes ("
        + ", ".join(f"{n} {s.options['patch_size']}" for n, s in SCHEMES.items()
                    if "patch_size" in s.options) + ").",
        show_default="per scheme",
    ),
    max_triangles_roam: int = typer.Option(
        None, "--roam-max-triangles", hidden=True,
        help="Deprecated alias of --triangles (kept so old scripts run).",
    ),
    mesher: str = typer.Option(
        None, "--mesher", help="Static mesher: " + "; ".join(
            f"{n} ({m.help})" for n, m in STATIC_MESHERS.items()) + ".",
        show_default=DEFAULT_STATIC_MESHER,
    ),
    one_piece: bool = typer.Option(
        False, "--one-piece",
        help="With --mesher " + ", ".join(_ONE_PIECE_MESHERS) + " and --max-error: one "
             "greedy order over the whole map "
             "instead of pieces meshed in parallel (no straight runs of edges where the "
             "pieces meet; slower on two threads, the most on dense meshes, whose pieces "
             "are decimated from every sample)."),
    fit: str = typer.Option(
        "none", "--fit",
        help="Non-(2**n+1) maps: none (static meshes take any size, view meshes refuse), "
        "pad (repeat edges) or resample (cubic).",
    ),
    texture: bool = typer.Option(
        True, "--texture/--no-texture",
        help=".glb: bake the terrain colour × sun and shadows into a base-colour texture.",
    ),
    normal_map: bool = typer.Option(
        False, "--normal-map", help=".glb: add a tangent-space normal map (and tangents)."
    ),
    quantize: bool = typer.Option(
        False, "--quantize",
        help=".glb: KHR_mesh_quantization (int16 positions, int8 normals, uint16 UVs).",
    ),
    compress: bool = typer.Option(
        False, "--compress",
        help=".glb: EXT_meshopt_compression on top of --quantize (implied): about a fifth of "
        "the plain file. three.js, Babylon.js and glTFast (Unity) decode it; Blender and Godot "
        "do not (use --quantize alone there).",
    ),
    uint16: bool = typer.Option(
        False, "--uint16",
        help=".glb: split meshes of 65535+ vertices into parts with 16-bit indices (WebGL 1 "
        "and other targets without 32-bit indices).",
    ),
    skirt: float = typer.Option(
        0.0, "--skirt", help=".glb: depth of a skirt hung from the border (world units; "
        "hides cracks between tiles).", show_default="none",
    ),
    georeference_node: bool = typer.Option(
        False, "--georeference-node",
        help=".glb: place the mesh at its projected CRS coordinates (root node translation); "
        "the CRS is always in the root node's extras.",
    ),
    spacing: str = typer.Option(
        None, "--spacing", help="Sample spacing DX or DX,DZ in world units (overrides file).",
        show_default="from file",
    ),
    vertical_scale: float = typer.Option(
        None, "--vertical-scale",
        help="World height of full scale for unitless formats (images), else a multiplier.",
        show_default="1 / unchanged",
    ),
    no_reproject: bool = NO_REPROJECT,
    force: bool = typer.Option(False, "--force", help="Overwrite the output file if it exists."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines."),
    max_memory: str = max_memory_option(
        "Refuse the map before meshing, or the mesh as soon as it is built (before it is "
        "measured and written),"),
) -> None:
    """Export a terrain mesh and print its triangle count and MEASURED maximum error."""
    from terrascape.io.atomic import check_output_path
    from terrascape.io.mesh import MESH_FORMATS, compact_mesh, write_mesh
    from terrascape.lod.mesh_checks import frustum_mask, max_vertical_error, screen_errors

    if output.suffix.lower() not in MESH_FORMATS:
        raise FileFormatError(
            f"output must end in {', '.join(MESH_FORMATS)}, got {output.name!r}"
        )
    check_output_path(output, force=force)
    if (compress or uint16) and output.suffix.lower() != ".glb":
        raise InvalidParameterError("--compress and --uint16 are for .glb output")
    if max_triangles_roam is not None:
        if triangles is not None and triangles != max_triangles_roam:
            raise InvalidParameterError(
                "give the triangle budget once: --triangles (--roam-max-triangles is its old name)")
        out.print("[yellow]note:[/] --roam-max-triangles is deprecated; use --triangles")
        triangles = max_triangles_roam
    view_mode = camera is not None or target is not None
    static_mode = max_error is not None or (triangles is not None and not view_mode)
    if view_mode and static_mode:
        raise InvalidParameterError(
            "choose one mode: --max-error/--triangles (static) or --camera/--target (view)"
        )
    if not view_mode and not static_mode:
        raise InvalidParameterError(
            "give --max-error METRES, --triangles N, or --camera X,Y,Z --target X,Y,Z"
        )
    if view_mode and (camera is None or target is None):
        raise InvalidParameterError("the view-dependent mode needs both --camera and --target")
    if lod not in SCHEMES:
        raise InvalidParameterError(f"--lod must be one of {', '.join(SCHEMES)}, got {lod!r}")
    entry = SCHEMES[lod] if view_mode else None
    if entry is not None:
        given = {"tolerance_px": tolerance, "max_triangles": triangles}
        for name, value in given.items():
            if value is not None and name not in entry.parameter_names:
                raise InvalidParameterError(f"--lod {lod} does not take {_FLAGS[name]}")
    if patch_size is not None and (entry is None or "patch_size" not in entry.options):
        raise InvalidParameterError(
            "--patch-size is for the view-dependent patch schemes (" + ", ".join(
                n for n, s in SCHEMES.items() if "patch_size" in s.options) + ")")
    if fit not in _FITS:
        raise InvalidParameterError(f"--fit must be one of {', '.join(_FITS)}, got {fit!r}")
    if mesher is not None and mesher not in STATIC_MESHERS:
        raise InvalidParameterError(
            f"--mesher must be one of {', '.join(STATIC_MESHERS)}, got {mesher!r}")
    if mesher is not None and view_mode:
        raise InvalidParameterError(
            f"--mesher {mesher} makes static meshes: use it with --max-error/--triangles, "
            "not --camera/--target (view-dependent meshes take --lod)")
    mesher = DEFAULT_STATIC_MESHER if mesher is None else mesher
    if one_piece and mesher not in _ONE_PIECE_MESHERS:
        raise InvalidParameterError(
            f"--one-piece is for --mesher {' or '.join(_ONE_PIECE_MESHERS)}")
    if max_triangles_roam is not None and not (view_mode and lod == "roam"):
        raise InvalidParameterError(
            "--roam-max-triangles applies only to the view-dependent ROAM mesh: add --lod roam "
            "with --camera/--target, or drop it (static meshes take --triangles N)"
        )

    use_max_memory(max_memory)
    with timed("read", quiet=quiet):
        hm = metric_map(_read(heightmap, spacing, vertical_scale), no_reproject=no_reproject)
        if fit != "none":
            hm = hm.to_pow2_plus1(fit)
    suffix = output.suffix.lower()
    check_grid("mesh glb" if suffix == ".glb" and texture else "mesh", hm.rows, hm.cols,
               hint="use a smaller map (or raise --max-memory)")
    if triangles is not None:
        _check_mesh_memory(triangles, suffix, budget=True)

    if static_mode:
        entry_mesher = STATIC_MESHERS[mesher]
        options = {"in_pieces": False} if one_piece else {}
        with timed(f"{entry_mesher.label} mesh", quiet=quiet,
                   slow_note=entry_mesher.first_run_note):
            tri = entry_mesher.mesh(hm, max_error=max_error, max_triangles=triangles, **options)
        _check_mesh_memory(len(tri), suffix)
        with timed("measure", quiet=quiet):
            measured = max_vertical_error(hm, tri)
        summary = f"max vertical error {measured:.6g} (world units, measured on every sample)"
    else:
        width, height = parse_size(size, name="--size")
        cam = Camera.look_at(
            parse_floats(camera, 3, name="--camera"),
            parse_floats(target, 3, name="--target"),
            fov_y=fov, aspect=width / height, near=0.1, far=1e9,
        )
        kwargs = {}
        if "tolerance_px" in entry.parameter_names:
            tolerance = _DEFAULT_TOLERANCE if tolerance is None else tolerance
            kwargs["tolerance_px"] = tolerance
        if triangles is not None:
            kwargs["max_triangles"] = triangles
        with timed(f"{lod} setup", quiet=quiet):
            lod_mesh = entry.build(hm, **({} if patch_size is None else {"patch_size": patch_size}))
        with timed(f"{lod} update", quiet=quiet):
            lod_mesh.update(cam, (width, height), **kwargs)
            tri = lod_mesh.triangles()
        _check_mesh_memory(len(tri), suffix)
        with timed("measure", quiet=quiet):
            per_sample = screen_errors(hm, tri, cam, (width, height))
            in_view = frustum_mask(hm, cam)
            screen = float(per_sample[in_view].max()) if in_view.any() else 0.0
            vertical = max_vertical_error(hm, tri)
        asked = f"tolerance {tolerance:g} px; " if "tolerance_px" in kwargs else ""
        summary = (
            f"max screen error {screen:.4g} px in view ({asked}"
            f"whole map {float(per_sample.max()):.4g} px), "
            f"max vertical error {vertical:.6g} (measured on every sample)"
        )

    with timed("write", quiet=quiet):
        if suffix == ".glb":
            from terrascape.export.glb import build_glb
            from terrascape.io.atomic import atomic_output

            data, mesh = build_glb(hm, tri, texture=texture, normal_map=normal_map,
                                   quantize=quantize, compress=compress,
                                   split_uint16=uint16, skirt=skirt,
                                   georeference_node=georeference_node)
            with atomic_output(output, force=force) as tmp:
                tmp.write_bytes(data)
            n_faces, n_vertices = len(tri), len(mesh.positions)
        else:
            vertices, faces = compact_mesh(hm, tri)
            write_mesh(output, vertices, faces, force=force)
            n_faces, n_vertices = len(faces), len(vertices)
    out.print(f"{output}: {n_faces} triangles, {n_vertices} vertices; {summary}")


def _check_mesh_memory(triangles: int, suffix: str, *, budget: bool = False) -> None:
    """Refuse a mesh whose measuring and writing would not fit in memory: before meshing
    for a triangle budget (the mesh has at most that many), after meshing otherwise (a
    mesh's size for an error is known only once it is built; the heights and triangles
    are in memory by then, the vertex arrays, the error measure and the file's buffers are
    not)."""
    check_triangles(triangles, suffix,
                    "a --triangles budget of up to" if budget
                    else "measuring and writing a mesh of",
                    hint="nothing was written; give a larger --max-error or a --triangles "
                         "budget (or raise --max-memory)")
