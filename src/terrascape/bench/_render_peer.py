"""Frame rate of the full-resolution terrain: terrascape's renderer against pyvista (VTK).

Both draw the same full-grid mesh (every sample a vertex, two triangles per cell, smooth
normals) at the same size from the same cameras, headless on the same GL (EGL; llvmpipe on a
machine without a GPU), with one directional light and no shadows: terrascape's plain
technique with per-vertex Phong lighting (``--lighting vertex``), pyvista's default smooth
shading. A frame is timed from the draw call to the pixels in a numpy array (our
``OffscreenRenderer.render`` reads the framebuffer back; pyvista's ``screenshot`` renders
and reads back), frames of the two interleaved camera by camera, so both share the
machine's load. Each row also says how much of each image the terrain covers: a ratio is
only a comparison if both pictures show the terrain. VTK's EGL context and ours do not share
a process (VTK crashes when another EGL context is current), so pyvista draws in a worker
process that answers one frame per request.
"""

from __future__ import annotations

import importlib.util
import math
import multiprocessing
import statistics
import time

import numpy as np

from terrascape.bench import BenchTable

FRAME_SIZE = (1280, 720)
CAMERAS = 6


def _cameras(renderer, n: int):
    from terrascape.bench.render import camera_path

    return camera_path(renderer, n)


def _coverage(img: np.ndarray, background: np.ndarray) -> float:
    """Share of pixels that differ from the background colour by more than 8 levels."""
    diff = np.abs(img[..., :3].astype(np.int16) - background[:3].astype(np.int16)).max(-1)
    return float(np.count_nonzero(diff > 8)) / diff.size


def _pyvista_worker(conn, heights: np.ndarray, spacing, size) -> None:
    """Worker process: build pyvista's mesh and plotter, then for each camera received
    ``(position, forward, fov_y, near, far)`` render one frame and send back
    ``(seconds, terrain coverage)``; ``None`` ends it."""
    import pyvista as pv

    dx, dz = spacing
    xs, zs = np.meshgrid(np.arange(heights.shape[1]) * dx, np.arange(heights.shape[0]) * dz)
    surface = pv.StructuredGrid(xs, heights.astype(np.float64), zs)
    surface = surface.extract_surface(algorithm=None).triangulate().compute_normals(
        cell_normals=False, split_vertices=False, consistent_normals=False,
        auto_orient_normals=False)  # fmt: skip
    plotter = pv.Plotter(off_screen=True, window_size=list(size))
    plotter.add_mesh(surface, color="tan", smooth_shading=True)
    plotter.background_color = "white"
    plotter.show(auto_close=False)
    conn.send(pv.__version__)
    white = np.array([255, 255, 255])
    while (msg := conn.recv()) is not None:
        position, forward, fov_y, near, far = msg
        t0 = time.perf_counter()
        eye = np.asarray(position, float)
        plotter.camera_position = [tuple(eye), tuple(eye + np.asarray(forward, float) * 100.0),
                                   (0.0, 1.0, 0.0)]  # fmt: skip
        plotter.camera.view_angle = float(fov_y)
        plotter.camera.clipping_range = (float(near), float(far))
        plotter.render()  # screenshot() alone returns the last image when nothing re-rendered
        img = plotter.screenshot(return_img=True)
        took = time.perf_counter() - t0
        conn.send((took, _coverage(img, white)))
    plotter.close()


def frame_rate_table(size: int, rounds: int) -> BenchTable:
    """One row: median ms per frame of both over ``rounds`` interleaved passes of the path."""
    table = BenchTable(
        f"Frames of the full {size}² mesh at {FRAME_SIZE[0]}×{FRAME_SIZE[1]}: terrascape vs "
        "pyvista",
        ["size", "peer", "ours ms/frame", "peer ms/frame", "ours/peer", "spread",
         "ours frames/s", "peer frames/s", "terrain in ours %", "terrain in peer %"],
    )  # fmt: skip
    if importlib.util.find_spec("pyvista") is None:
        table.rows.append([f"{size}²", "pyvista", *["-"] * 8])
        table.notes.append("pyvista is not installed (pip install pyvista)")
        return table
    from terrascape.bench.shade import terrain
    from terrascape.render.context import describe_context, headless_context
    from terrascape.render.offscreen import OffscreenRenderer

    hm = terrain(size)
    # no sky: pyvista draws none, and a plain background lets both count terrain pixels
    params = {"lighting": "vertex", "sky": False}
    mp = multiprocessing.get_context("spawn")
    parent, child = mp.Pipe()
    worker = mp.Process(target=_pyvista_worker, args=(child, hm.heights, hm.spacing,
                                                      FRAME_SIZE), daemon=True)  # fmt: skip
    worker.start()
    try:
        peer_version = parent.recv()
        with headless_context() as ctx:
            info = describe_context(ctx)
            ours = OffscreenRenderer(ctx, hm, size=FRAME_SIZE)
            try:
                cams = _cameras(ours, CAMERAS)

                def peer_frame(cam):
                    parent.send((tuple(cam.position), tuple(cam.forward), cam.fov_y,
                                 cam.near, cam.far))  # fmt: skip
                    return parent.recv()

                def our_frame(cam):
                    t0 = time.perf_counter()
                    img = ours.render(cam, "plain", params)
                    ctx.finish()
                    return time.perf_counter() - t0, _coverage(img, img[0, 0])

                # warm-up (shader compile, first upload) and each picture's coverage
                _, cover_ours = our_frame(cams[0])
                _, cover_peer = peer_frame(cams[0])
                t_ours, t_peer, ratios = [], [], []
                for k in range(rounds):
                    for i, cam in enumerate(cams):
                        jobs = [(0, our_frame), (1, peer_frame)]
                        if (k + i) % 2:
                            jobs.reverse()
                        took = [0.0, 0.0]
                        for slot, job in jobs:
                            took[slot] = job(cam)[0]
                        t_ours.append(took[0])
                        t_peer.append(took[1])
                        ratios.append(took[0] / took[1])
            finally:
                ours.release()
    finally:
        if worker.is_alive():
            parent.send(None)
        worker.join(timeout=30)
        if worker.is_alive():  # pragma: no cover - a hung VTK
            worker.kill()
    ms_o, ms_p = statistics.median(t_ours) * 1e3, statistics.median(t_peer) * 1e3
    table.rows.append([
        f"{size}²", f"pyvista {peer_version}", ms_o, ms_p, statistics.median(ratios),
        f"{min(ratios):.2f}–{max(ratios):.2f}", 1e3 / ms_o, 1e3 / ms_p,
        round(100 * cover_ours, 1), round(100 * cover_peer, 1),
    ])  # fmt: skip
    table.notes += [
        f"{info['renderer']}; {math.prod(hm.shape):,} vertices, "
        f"{2 * (hm.rows - 1) * (hm.cols - 1):,} triangles each; {CAMERAS} cameras on an arc "
        f"(`bench render`'s path) × {rounds} rounds, the two renderers interleaved per frame",
        "ours: plain technique, per-vertex Phong (lighting 'vertex'), no sky; pyvista: add_mesh "
        "smooth_shading, default light kit; a frame = draw + read the pixels back",
    ]
    return table


__all__ = ["frame_rate_table"]
