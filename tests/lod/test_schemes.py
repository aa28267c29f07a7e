"""The LOD schemes' common interface and the SCHEMES table every front end reads."""

from __future__ import annotations

import re
import subprocess
import sys

import numpy as np
import pytest
from scipy import ndimage

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.lod import is_conforming
from terrascape.lod.schemes import SCHEMES, LodScheme, LodStats, scheme

VIEWPORT = (320, 180)


@pytest.fixture(scope="module")
def hm():
    rng = np.random.default_rng(11)
    h = (ndimage.gaussian_filter(rng.standard_normal((129, 129)), 4) * 300).astype(np.float32)
    return Heightmap(h, spacing=(4.0, 4.0))


def _camera():
    return Camera.look_at((-60.0, 260.0, -60.0), (300.0, 0.0, 300.0), aspect=16 / 9,
                          near=1.0, far=5000.0)


@pytest.mark.parametrize("name", list(SCHEMES))
def test_every_scheme_follows_the_interface(hm, name):
    entry = SCHEMES[name]
    lod = entry.build(hm)
    assert isinstance(lod, entry.load()) and isinstance(lod, LodScheme)
    settings = {p.name: p.default for p in entry.adjustable if p.default not in (None, p.off)}
    if "max_triangles" in settings:
        settings["max_triangles"] = 3000
    cam = _camera()
    st = lod.update(cam, VIEWPORT, **settings)
    for _ in range(8):  # Turner's feedback settles over frames
        if st.settled:
            break
        st = lod.update(cam, VIEWPORT, **settings)
    assert isinstance(st, LodStats) and st.settled and st.summary and st.update_ms >= 0
    tris = lod.triangles()
    assert tris.dtype == np.uint32 and tris.ndim == 2 and tris.shape[1] == 3
    assert int(tris.max()) < hm.rows * hm.cols
    if "max_triangles" in settings:
        assert len(tris) <= 3000 * 1.05
    visible = lod.triangles(visible_only=True)
    assert 0 < len(visible) <= len(tris)
    # the whole-map mesh tiles the grid without cracks; visible_only keeps only its rows
    assert is_conforming(tris, hm.shape)
    rows = {tuple(t) for t in np.sort(tris, axis=1).tolist()}
    assert all(tuple(t) in rows for t in np.sort(visible, axis=1).tolist())
    # a setting the table does not list for the scheme is refused, not ignored
    for other in ("tolerance_px", "max_triangles", "time_budget_ms"):
        if other not in entry.parameter_names:
            with pytest.raises(InvalidParameterError, match="does not take"):
                lod.update(cam, VIEWPORT, **{other: 1000})


def test_roam_visible_only_drops_exactly_the_triangles_outside_the_frustum(hm):
    roam = SCHEMES["roam"].build(hm)
    cam = _camera()
    roam.update(cam, VIEWPORT, max_triangles=4000)
    tris, visible = roam.triangles(), roam.triangles(visible_only=True)
    assert len(visible) < len(tris)
    dx, dz = hm.spacing
    flat = tris.astype(np.int64)
    pts = np.stack([(flat % hm.cols) * dx, hm.heights.reshape(-1)[flat], (flat // hm.cols) * dz],
                   axis=-1)
    planes = cam.frustum_planes()
    side = pts @ planes[:, :3].T + planes[:, 3]  # (M, 3 corners, 6 planes)
    outside = np.any(np.all(side < 0, axis=1), axis=1)
    assert len(visible) == int((~outside).sum())


def test_turner_retarget_equals_a_new_instance(hm):
    cam = _camera()
    moved = scheme("turner").build(hm)
    moved.update(cam, VIEWPORT, max_triangles=5000)
    moved.update(cam, VIEWPORT, max_triangles=2000)
    fresh = scheme("turner").build(hm, target_triangles=2000)
    fresh.update(cam, VIEWPORT)
    assert np.array_equal(np.sort(moved.triangles(), axis=None),
                          np.sort(fresh.triangles(), axis=None))


def test_geomipmap_visible_only_is_update_with_cull(hm):
    cam = Camera.look_at((40.0, 120.0, 40.0), (480.0, 0.0, 200.0), fov_y=40.0, aspect=16 / 9,
                         near=1.0, far=5000.0)
    a, b = SCHEMES["geomipmap"].build(hm), SCHEMES["geomipmap"].build(hm)
    a.update(cam, VIEWPORT, tolerance_px=2.0)
    b.update(cam, VIEWPORT, 2.0, cull=True)
    assert np.array_equal(a.triangles(visible_only=True), b.triangles())
    assert len(a.triangles()) > len(b.triangles())


def test_unknown_scheme_is_one_line():
    with pytest.raises(InvalidParameterError, match="roam, turner, geomipmap"):
        scheme("quadtree")


def test_parameter_steps():
    tol = SCHEMES["roam"].parameter("tolerance_px")
    assert tol.stepped(0.0, finer=False) == tol.minimum  # off → the smallest tolerance
    assert tol.stepped(0.0, finer=True) == 0.0
    assert tol.stepped(tol.minimum, finer=True) == 0.0  # below the minimum → off again
    budget = SCHEMES["turner"].parameter("max_triangles")
    assert budget.stepped(80_000, finer=True) == 100_000
    assert budget.stepped(budget.maximum, finer=True) == budget.maximum


def _help(*args: str) -> str:
    out = subprocess.run(
        [sys.executable, "-c", "from terrascape.cli import main; main()", *args, "--help"],
        capture_output=True, text=True, check=True, env={"COLUMNS": "400", "PATH": "",
                                                         "PYTHONPATH": ":".join(sys.path)})
    return re.sub(r"\s+", " ", out.stdout)


def test_front_ends_list_exactly_the_table():
    from terrascape.viewer.controls import HELP, LOD_MODES, ViewerState

    names = list(SCHEMES)
    assert ("none", *names) == LOD_MODES
    seen, state = [], ViewerState()
    for _ in LOD_MODES:
        state.handle_key("L")
        seen.append(state.lod)
    assert seen == [*names, "none"]
    assert "none / " + " / ".join(names) in dict(HELP)["L"]
    view = _help("view")
    assert f"none, {', '.join(names)}" in view
    mesh = _help("mesh")
    for name in names:
        assert f"{name} (" in mesh
