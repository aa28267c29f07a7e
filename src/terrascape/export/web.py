"""A self-contained web page showing the textured terrain: ``terrascape export web``.

The page (``index.html``) embeds the quantized, meshopt-compressed, textured glb
(:mod:`terrascape.export.glb`) as base64 and three.js (npm ``three``, vendored under
``web_assets/three`` with its MIT licence by ``scripts/vendor_three.sh``, with meshoptimizer's
decoder from three's ``examples/jsm/libs``, MIT too): it opens from ``file://`` — module
scripts cannot be fetched there, so the modules are inlined as text and imported from
``blob:`` URLs — and from any static server. The glb is also written next to it
(``NAME.glb``). The viewer draws the baked colour texture unlit (it already holds the sun and
the shadows) with orbit controls; ``index.html#top`` looks straight down at the whole map.
"""

from __future__ import annotations

import base64
import json
from importlib import resources
from pathlib import Path

from terrascape.export._common import (
    ExportOptions,
    check_out_dir,
    one_unit,
    write_bytes,
    write_text,
)
from terrascape.heightmap import Heightmap

NAME = "web"
SUMMARY = "Static web page (three.js, works from file://) with the textured glb embedded."
#: the page's terrain is meshed by ``ExportOptions.mesher``
TAKES_MESHER = True
SKY = "#a9c8e8"

_MODULES = {
    "THREE_CORE": "three/three.core.js",
    "THREE_MODULE": "three/three.module.js",
    "THREE_BGU": "three/BufferGeometryUtils.js",
    "THREE_SKU": "three/SkeletonUtils.js",
    "THREE_GLTF": "three/GLTFLoader.js",
    "THREE_ORBIT": "three/OrbitControls.js",
    "MESHOPT_DECODER": "three/meshopt_decoder.module.js",
    "VIEWER": "viewer.js",
}


def _asset(name: str) -> str:
    return (resources.files("terrascape.export") / "web_assets" / name).read_text("utf-8")


def page_html(glb: bytes, *, title: str, sky: str = SKY) -> str:
    """The viewer page with ``glb`` embedded."""
    html = _asset("page.html")
    config = json.dumps({"sky": sky, "title": title})
    fields = {
        "SKY": sky,
        "INFO": title.replace("&", "&amp;").replace("<", "&lt;"),
        "THREE_VERSION": _asset("three/VERSION").split()[-1],
        "CONFIG": config.replace("</", "<\\/"),
        "GLB": base64.b64encode(glb).decode("ascii"),
    }
    for key, name in _MODULES.items():
        source = _asset(name)
        if "</script" in source.lower():  # would end the inline block early
            raise RuntimeError(f"{name} contains '</script'; cannot inline it")
        fields[key] = source
    for key, value in fields.items():
        html = html.replace(f"@{key}@", value)
    return html


@one_unit
def export(heightmap: Heightmap, out_dir, options: ExportOptions) -> list[Path]:
    from terrascape.export.glb import build_glb
    from terrascape.export.instances import objects_for
    from terrascape.lod.mesh_checks import max_vertical_error
    from terrascape.lod.static_meshers import static_mesher
    from terrascape.memory import check_triangles

    out = check_out_dir(out_dir)
    relief = max(heightmap.max - heightmap.min, 1e-6)
    max_error = options.max_error if options.max_error is not None else relief / 500.0
    tri = static_mesher(options.mesher).mesh(heightmap, max_error=max_error)
    # the mesh's size is known only now: refused before its glb and page are built
    check_triangles(len(tri), "web", "the web page of a mesh of")
    glb, mesh = build_glb(heightmap, tri, compress=True, texture_size=2048,
                          objects=objects_for(options, heightmap))
    measured = max_vertical_error(heightmap, tri)
    title = (f"{options.name}: {heightmap.cols}×{heightmap.rows} samples, {len(mesh.faces):,} "
             f"triangles (max error {measured:.3g}, measured)")
    glb_path = write_bytes(out / f"{options.name}.glb", glb, force=options.force)
    page = write_text(out / "index.html", page_html(glb, title=title), force=options.force)
    lic = write_text(out / "THREE_LICENSE.txt", _asset("three/LICENSE"), force=options.force)
    return [page, glb_path, lic]
