"""``terrascape mesh`` — export a terrain mesh (OBJ / PLY / GLB) at a measured error.

Three modes:

* ``--max-error METRES`` and/or ``--triangles N``: static RTIN mesh with a true maximum
  vertical error / a hard triangle budget (:mod:`terrascape.lod.rtin`);
* ``--camera X,Y,Z --target X,Y,Z --tolerance PIXELS``: the view-dependent mesh a renderer
  would draw from that camera (geomipmapping, or ROAM with ``--lod roam``).

The printed error is always MEASURED on every grid sample (vertical error in world units;
screen-space pixels for the view-dependent mode), never the requested value.
"""

from __future__ import annotations

from pathlib import Path

import typer

from terrascape.cli.app import app, out, timed
from terrascape.cli.parsing import parse_floats, parse_size
from terrascape.errors import FileFormatError, InvalidParameterError, TerrascapeError

_LODS = ("geomipmap", "roam")
_FITS = ("none", "pad", "resample")


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
        None, "--triangles", help="Static mesh: hard triangle budget (never exceeded).",
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
        2.0, "--tolerance", help="View-dependent mesh: screen-space error tolerance τ (pixels)."
    ),
    lod: str = typer.Option(
        "geomipmap", "--lod", help="View-dependent algorithm: geomipmap or roam."
    ),
    size: str = typer.Option(
        "1920x1080", "--size", help="View-dependent mesh: viewport WIDTHxHEIGHT (pixels)."
    ),
    fov: float = typer.Option(60.0, "--fov", help="Vertical field of view (degrees)."),
    patch_size: int = typer.Option(
        17, "--patch-size", help="Geomipmapping patch size in samples (2**k + 1)."
    ),
    max_triangles_roam: int = typer.Option(
        None, "--roam-max-triangles", help="ROAM only: triangle budget per frame.",
        show_default="off",
    ),
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
    force: bool = typer.Option(False, "--force", help="Overwrite the output file if it exists."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No timing lines."),
) -> None:
    """Export a terrain mesh and print its triangle count and MEASURED maximum error."""
    from terrascape.camera import Camera
    from terrascape.io.atomic import check_output_path
    from terrascape.io.mesh import MESH_FORMATS, compact_mesh, write_mesh
    from terrascape.lod.mesh_checks import frustum_mask, max_vertical_error, screen_errors

    if output.suffix.lower() not in MESH_FORMATS:
        raise FileFormatError(
            f"output must end in {', '.join(MESH_FORMATS)}, got {output.name!r}"
        )
    check_output_path(output, force=force)
    view_mode = camera is not None or target is not None
    static_mode = max_error is not None or triangles is not None
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
    if lod not in _LODS:
        raise InvalidParameterError(f"--lod must be one of {', '.join(_LODS)}, got {lod!r}")
    if fit not in _FITS:
        raise InvalidParameterError(f"--fit must be one of {', '.join(_FITS)}, got {fit!r}")

    with timed("read", quiet=quiet):
        hm = _read(heightmap, spacing, vertical_scale)
        if fit != "none":
            hm = hm.to_pow2_plus1(fit)

    if static_mode:
        from terrascape.export.meshing import rtin_rectangle
        from terrascape.lod.rtin import Rtin

        if triangles is None or not hm.is_pow2_plus1:
            # one error: the fast path skips most exact triangle errors; any other size is
            # padded internally and the triangles outside the data are dropped
            with timed("rtin mesh", quiet=quiet):
                tri = rtin_rectangle(hm, max_error=max_error, max_triangles=triangles)
        else:
            with timed("rtin errors", quiet=quiet):
                rtin = Rtin(hm)
            with timed("rtin mesh", quiet=quiet):
                tri = rtin.mesh(max_error=max_error, max_triangles=triangles).triangles
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
        if lod == "geomipmap":
            from terrascape.lod.geomipmap import Geomipmap

            with timed("geomipmap setup", quiet=quiet):
                gm = Geomipmap(hm, patch_size)
            with timed("geomipmap update", quiet=quiet):
                gm.update(cam, (width, height), tolerance)
                tri = gm.triangles()
        else:
            try:
                from terrascape.lod.roam import Roam
            except ImportError:
                raise InvalidParameterError(
                    "--lod roam is not available in this build (terrascape.lod.roam missing)"
                ) from None
            with timed("roam setup", quiet=quiet):
                roam = Roam(hm)
            with timed("roam update", quiet=quiet):
                kwargs = {"tolerance_px": tolerance}
                if max_triangles_roam is not None:
                    kwargs["max_triangles"] = max_triangles_roam
                roam.update(cam, (width, height), **kwargs)
                tri = roam.triangles()
        with timed("measure", quiet=quiet):
            per_sample = screen_errors(hm, tri, cam, (width, height))
            in_view = frustum_mask(hm, cam)
            screen = float(per_sample[in_view].max()) if in_view.any() else 0.0
            vertical = max_vertical_error(hm, tri)
        summary = (
            f"max screen error {screen:.4g} px in view (tolerance {tolerance:g} px; "
            f"whole map {float(per_sample.max()):.4g} px), "
            f"max vertical error {vertical:.6g} (measured on every sample)"
        )

    with timed("write", quiet=quiet):
        if output.suffix.lower() == ".glb":
            from terrascape.export.glb import build_glb
            from terrascape.io.atomic import atomic_output

            data, mesh = build_glb(hm, tri, texture=texture, normal_map=normal_map,
                                   quantize=quantize, skirt=skirt,
                                   georeference_node=georeference_node)
            with atomic_output(output, force=force) as tmp:
                tmp.write_bytes(data)
            n_faces, n_vertices = len(tri), len(mesh.positions)
        else:
            vertices, faces = compact_mesh(hm, tri)
            write_mesh(output, vertices, faces, force=force)
            n_faces, n_vertices = len(faces), len(vertices)
    out.print(f"{output}: {n_faces} triangles, {n_vertices} vertices; {summary}")
