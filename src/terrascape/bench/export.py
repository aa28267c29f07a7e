"""Benchmark: time and size of every export target for one terrain (``terrascape bench export``).

A 4097² diamond-square terrain (``--quick``: 1025²), 10 m spacing, 0–1500 m, placed at
15.97° E 45.81° N for the web pyramids, written to:

* glb, plain (float32 attributes) and quantized (``KHR_mesh_quantization``), the same RTIN mesh
  (same error), geometry only, and the plain glb with its baked texture; target: quantized ≤
  0.45 × plain bytes;
* the Cesium quantized-mesh pyramid, with its worker processes; target: ≤ 60 s on two cores;
* the Terrain-RGB PNG pyramid.
"""

from __future__ import annotations

import resource
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from terrascape.bench import BenchTable
from terrascape.export import ExportOptions, get_destination
from terrascape.export.glb import build_glb
from terrascape.export.meshing import rtin_rectangle
from terrascape.generate import diamond_square

_LONLAT = (15.97, 45.81)
_QUANTIZED_RATIO_TARGET = 0.45
_PYRAMID_SECONDS_TARGET = 60.0


def _timed(func: Callable[[], Any]) -> tuple[Any, float, float]:
    """``(result, wall seconds, CPU seconds of this process and its finished children)``."""
    def cpu() -> float:
        own = resource.getrusage(resource.RUSAGE_SELF)
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime

    c0, t0 = cpu(), time.perf_counter()
    result = func()
    return result, time.perf_counter() - t0, cpu() - c0


def _folder_bytes(folder: Path) -> tuple[int, int]:
    files = [p for p in folder.rglob("*") if p.is_file()]
    return len(files), sum(p.stat().st_size for p in files)


def _quantized_position_error(mesh, data: bytes) -> float:
    """Largest |decoded − original| position coordinate of a quantized glb, world units."""
    import pygltflib

    doc = pygltflib.GLTF2.load_from_bytes(data)
    blob = doc.binary_blob()
    acc = doc.accessors[doc.meshes[0].primitives[0].attributes.POSITION]
    view = doc.bufferViews[acc.bufferView]
    raw = np.frombuffer(blob, "<i2", acc.count * 4, view.byteOffset).reshape(-1, 4)[:, :3]
    node = doc.nodes[1]
    decoded = np.asarray(node.translation) + np.asarray(node.scale) * np.maximum(
        raw / 32767.0, -1.0)
    return float(np.abs(decoded - mesh.positions).max())


def run(quick: bool = False) -> list[BenchTable]:
    """One row per target: seconds, bytes, and whether its target was met."""
    side = 1025 if quick else 4097
    hm = diamond_square(side, roughness=0.55, seed=7, spacing=10.0).normalised(0.0, 1500.0)
    error = 1.0
    table = BenchTable(
        title=f"export targets, {side}×{side} terrain (10 m spacing, 0–1500 m)",
        columns=["target", "wall s", "CPU s", "MiB", "detail", "target met"],
    )
    tri, t_mesh, c_mesh = _timed(lambda: rtin_rectangle(hm, max_error=error))
    (plain, mesh), t_plain, c_plain = _timed(lambda: build_glb(hm, tri, texture=False))
    (quantized, _), t_quant, c_quant = _timed(
        lambda: build_glb(hm, tri, texture=False, quantize=True))
    ratio = len(quantized) / len(plain)
    q_err = _quantized_position_error(mesh, quantized)
    table.rows.append([f"RTIN mesh, max error {error:g} m", t_mesh, c_mesh, 0.0,
                       f"{len(tri):,} triangles, {len(mesh.positions):,} vertices", "—"])
    table.rows.append(["glb plain (geometry)", t_plain, c_plain, len(plain) / 2**20,
                       "float32 POSITION/NORMAL/TEXCOORD_0", "—"])
    table.rows.append(["glb quantized (geometry)", t_quant, c_quant, len(quantized) / 2**20,
                       f"{ratio:.3f}× plain; positions within {q_err:.3g} m",
                       "yes" if ratio <= _QUANTIZED_RATIO_TARGET else
                       f"no (target ≤ {_QUANTIZED_RATIO_TARGET})"])
    (textured, _), t_tex, c_tex = _timed(
        lambda: build_glb(hm, tri, texture=True, quantize=True, texture_size=4096))
    table.rows.append(["glb quantized + baked texture", t_tex, c_tex, len(textured) / 2**20,
                       "texture = regions × lightmap (PNG)", "—"])
    with tempfile.TemporaryDirectory(prefix="terrascape-bench-export-") as tmp:
        folder = Path(tmp) / "cesium"
        _, t_qm, c_qm = _timed(lambda: get_destination("cesium").export(
            hm, folder, ExportOptions(name="bench", lonlat=_LONLAT, workers=2)))
        n, size = _folder_bytes(folder)
        table.rows.append(["quantized-mesh pyramid", t_qm, c_qm, size / 2**20,
                           f"{n:,} files (gzip), 2 worker processes",
                           "yes" if t_qm <= _PYRAMID_SECONDS_TARGET else
                           f"no (target ≤ {_PYRAMID_SECONDS_TARGET:g} s wall)"])
        folder = Path(tmp) / "rgb"
        _, t_rgb, c_rgb = _timed(lambda: get_destination("terrain_rgb").export(
            hm, folder, ExportOptions(name="bench", lonlat=_LONLAT)))
        n, size = _folder_bytes(folder)
        table.rows.append(["Terrain-RGB pyramid", t_rgb, c_rgb, size / 2**20, f"{n:,} files",
                           "—"])
    table.notes.append("one run each on a shared 2-core machine: wall seconds drift with its "
                       "load; CPU seconds (this process + its worker processes) much less")
    table.notes.append("the glb byte ratio compares the same mesh (same RTIN error); the "
                       "quantized positions add the error shown")
    return [table]
