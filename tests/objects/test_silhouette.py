import warnings

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.objects import Instances, ObjectMesh
from terrascape.objects.silhouette import (
    OpenMeshWarning,
    mesh_edges,
    mesh_volume,
    shadow_volume,
    welded,
)


def box(name="box", size=(1.0, 1.0, 1.0)):
    """Flat-shaded box (4 vertices per face, so edges meet only by position), its foot at
    the origin, counter-clockwise from outside."""
    sx, sy, sz = (s / 2 for s in size)
    faces = [  # (normal, 4 corners counter-clockwise seen from outside)
        ((1, 0, 0), [(1, -1, 1), (1, -1, -1), (1, 1, -1), (1, 1, 1)]),
        ((-1, 0, 0), [(-1, -1, -1), (-1, -1, 1), (-1, 1, 1), (-1, 1, -1)]),
        ((0, 1, 0), [(-1, 1, 1), (1, 1, 1), (1, 1, -1), (-1, 1, -1)]),
        ((0, -1, 0), [(-1, -1, -1), (1, -1, -1), (1, -1, 1), (-1, -1, 1)]),
        ((0, 0, 1), [(-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]),
        ((0, 0, -1), [(1, -1, -1), (-1, -1, -1), (-1, 1, -1), (1, 1, -1)]),
    ]
    pos, nrm, idx = [], [], []
    for n, quad in faces:
        base = len(pos)
        pos += [(x * sx, (y + 1) * sy, z * sz) for x, y, z in quad]
        nrm += [n] * 4
        idx += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    pos = np.array(pos, np.float32)
    return ObjectMesh(name, pos, np.array(nrm, np.float32), np.full_like(pos, 0.6), idx)


def _outward(mesh):
    p, t = welded(mesh)
    tri = p[t]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centre = p.mean(axis=0)
    return np.einsum("ij,ij->i", n, tri.mean(axis=1) - centre) > 0


def _closed_counts(vol):
    """(directed edge -> count) of a triangle soup of homogeneous vertices."""
    from collections import Counter

    edges = Counter()
    for tri in vol.astype(np.float64):
        keys = [tuple(np.round(v, 5)) for v in tri]
        for k in range(3):
            edges[(keys[k], keys[(k + 1) % 3])] += 1
    return edges


def test_box_is_closed_and_welded():
    b = box()
    assert np.all(_outward(b))
    e = mesh_edges(welded(b)[1])
    assert e.closed and len(e.edges) == 18  # 12 box edges + 6 face diagonals
    # the flat-shaded vertices alone share no edges: 4 open edges per face
    assert mesh_edges(b.indices).open_edges == 24


@pytest.mark.parametrize(
    ("light", "caps", "sides"),
    [
        ((0.0, 1.0, 0.0, 0.0), 2, 4),  # straight down: the top face lit, a square silhouette
        ((0.3, 0.8, 0.5, 0.0), 6, 6),  # three faces lit, a hexagonal silhouette
        ((3.0, 4.0, 2.0, 1.0), 6, 6),  # a point light toward the same corner
    ],
)
def test_cube_volume_counts_and_closed(light, caps, sides):
    vol = mesh_volume(box(), np.eye(4)[None], light)
    point = light[3] == 1.0
    assert vol.shape == ((caps + sides) * (2 if point else 1), 3, 4)
    w = vol[..., 3]
    assert (w[:caps * (2 if point else 1)].sum() > 0) and set(np.unique(w)) <= {0.0, 1.0}
    edges = _closed_counts(vol)
    # closed: every directed edge once, and its reverse once
    assert all(n == 1 for n in edges.values())
    assert all(edges.get((b, a)) == 1 for a, b in edges)
    if not point:  # every vertex at infinity is the one point (-L, 0)
        d = np.array(light[:3]) / np.linalg.norm(light[:3])
        inf = vol[w == 0][:, :3]
        np.testing.assert_allclose(inf, np.broadcast_to(-d, inf.shape), atol=1e-6)


def test_side_quads_face_out_of_the_volume():
    # sun straight down onto a unit box: each side triangle's normal points away from the
    # box's vertical axis (the volume's outside)
    vol = mesh_volume(box(), np.eye(4)[None], (0, 1, 0))
    sides = vol[vol[..., 3].min(axis=1) == 0]
    finite = sides[:, :2, :3].astype(np.float64)  # the two vertices on the box
    # triangle (q, p, p'): normal (p − q) × (p' − q), and p' − q runs along the extrusion
    n = np.cross(finite[:, 1] - finite[:, 0], [0.0, -1.0, 0.0])
    mid = finite.mean(axis=1)
    out = mid - np.array([0.0, mid[0, 1], 0.0])
    assert np.all(np.einsum("ij,ij->i", n, out) > 0)


def test_instances_follow_their_matrices():
    b = box()
    inst = Instances((b,), [0, 0], [[10, 0, 0], [0, 0, 20]], [2.0, 1.0], [0.3, 0.0])
    vol = shadow_volume(inst, (0, 1, 0))
    assert vol.shape == (12, 3, 4)
    caps = vol[vol[..., 3].min(axis=1) == 1]
    # the first instance's top face at height 2 (scale 2), around x = 10
    top = caps[:2, :, :3]
    np.testing.assert_allclose(top[..., 1], 2.0, atol=1e-6)
    assert np.all(np.abs(top[..., 0] - 10.0) < 1.5)


def test_open_mesh_warns_once_and_still_closes():
    # a single square facing up: open edges; lit from above it casts its own square
    p = np.array([[0, 0, 0], [1, 0, 0], [1, 0, -1], [0, 0, -1]], np.float32)
    sheet = ObjectMesh("sheet-test", p, np.tile([0, 1, 0], (4, 1)), np.ones((4, 3)),
                       [[0, 1, 2], [0, 2, 3]])
    with pytest.warns(OpenMeshWarning, match="not closed"):
        vol = mesh_volume(sheet, np.eye(4)[None], (0, 1, 0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mesh_volume(sheet, np.eye(4)[None], (0, 1, 0))
    assert vol.shape == (2 + 4, 3, 4)
    edges = _closed_counts(vol)
    assert all(edges.get((b, a)) == 1 for a, b in edges)


def test_bad_light():
    with pytest.raises(InvalidParameterError, match="w must"):
        mesh_volume(box(), np.eye(4)[None], (0, 1, 0, 2))
    with pytest.raises(InvalidParameterError, match="non-zero"):
        mesh_volume(box(), np.eye(4)[None], (0, 0, 0))


def test_casters_in_view_keep_what_can_shadow_the_view():
    from terrascape.camera import Camera
    from terrascape.objects import Instances, builtin_meshes
    from terrascape.objects.silhouette import bounding_spheres, casters_in_view

    tree = builtin_meshes()["conifer"]
    # a camera at the origin looking north (−z) over flat ground at height 0
    cam = Camera(position=(0.0, 10.0, 0.0), yaw=0.0, pitch=-20.0, near=0.5, far=400.0)
    sun = np.array([0.0, 1.0, -1.0]) / np.sqrt(2.0)  # in the north, 45° high
    pos = [[0, 0, -50],   # in view
           [0, 0, 30],    # behind the camera, shadow falls further behind: culled
           [0, 0, -900],  # beyond the far plane, its shadow too: culled
           [80, 0, -60],  # off to the right, shadow falls south: culled
           [0, 0, 40]]    # behind the camera, but tall: its shadow reaches the view
    inst = Instances((tree,), [0] * 5, pos, [1, 1, 1, 1, 10.0], [0] * 5)
    keep = casters_in_view(inst, cam.frustum_planes(), sun, floor=0.0)
    assert keep.tolist() == [True, False, False, False, True]
    # a shadow falling away from the view stays culled however deep the floor
    deep = casters_in_view(inst, cam.frustum_planes(), sun, floor=-1000.0)
    assert not deep[1] and not deep[3] and deep[0] and deep[4]
    # a sun in the south throws the shadow of the tree behind the camera toward the view:
    # too short to reach the ground it sees, but it would reach ground 1000 below
    south = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)
    assert not casters_in_view(inst, cam.frustum_planes(), south, floor=0.0)[1]
    assert casters_in_view(inst, cam.frustum_planes(), south, floor=-1000.0)[1]
    # a sun under the horizon casts nothing; point lights are not culled
    assert not casters_in_view(inst, cam.frustum_planes(), [0, -1, 0], 0.0).any()
    assert casters_in_view(inst, cam.frustum_planes(), [0, 50, 0, 1], 0.0).all()
    c, r = bounding_spheres(inst)
    assert np.allclose(c[:, [0, 2]], np.asarray(pos, float)[:, [0, 2]])
    assert r[4] == pytest.approx(10.0 * r[0])


def _cut_reference(triangles, light, floor):
    """The cut volume from the volume to infinity in plain numpy (the implementation before
    the numba kernels): near caps, far caps slid onto y = floor and reversed, two triangles
    per side."""
    tri = np.asarray(triangles, np.float32)
    d = np.asarray(light, np.float64)
    d = d / np.linalg.norm(d)

    def down(v):
        t = np.maximum(v[:, 1].astype(np.float64) - floor, 0.0) / d[1]
        out = np.empty_like(v)
        out[:, :3] = v[:, :3] - (t[:, None] * d).astype(np.float32)
        out[:, 1] = np.where(v[:, 1] > floor, np.float32(floor), v[:, 1])
        out[:, 3] = 1.0
        return out

    side = tri[:, 2, 3] == 0.0
    caps, sides = tri[~side], tri[side]
    far = down(caps.reshape(-1, 4)).reshape(-1, 3, 4)[:, ::-1]
    q, p = sides[:, 0], sides[:, 1]
    p2, q2 = down(p), down(q)
    return np.concatenate([caps, far, np.stack([q, p, p2], axis=1),
                           np.stack([q, p2, q2], axis=1)])


def _scene(n, seed):
    from terrascape.objects import builtin_meshes

    meshes = builtin_meshes()
    rng = np.random.default_rng(seed)
    kinds = tuple(meshes[k] for k in ("conifer", "broadleaf", "house", "rock"))
    return Instances(kinds, rng.integers(0, 4, n), rng.uniform(-50, 50, (n, 3)),
                     rng.uniform(0.5, 2.0, n), rng.uniform(0, 2 * np.pi, n))


@pytest.mark.parametrize("light", [(0.3, 0.8, 0.5), (-0.7, 0.2, 0.1), (0.0, 1.0, 0.0),
                                   (0.05, 0.1, -1.0)])
@pytest.mark.parametrize("seed", [1, 2])
def test_cut_volume_equals_the_numpy_reference(light, seed):
    inst = _scene(60, seed)
    keep = np.random.default_rng(seed).random(len(inst)) < 0.8
    floor = -60.0
    ref = _cut_reference(shadow_volume(inst, light, keep), light, floor)
    got = shadow_volume(inst, light, keep, floor=floor)
    assert got.dtype == np.float32 and np.array_equal(got, ref)
    # written into a buffer with room: the same rows, the buffer's leading ones
    buf = np.full((len(ref) + 7, 3, 4), np.nan, np.float32)
    again = shadow_volume(inst, light, keep, floor=floor, out=buf)
    assert again.base is buf and np.array_equal(again, ref)
    assert np.isnan(buf[len(ref):]).all()


def test_bounded_volume_is_closed_outward_and_ends_at_the_floor():
    light = (0.3, 0.8, 0.5)
    inst = Instances((box(),), [0], [[0.0, 2.0, 0.0]], [1.0], [0.0])  # from y = 2 to 3
    vol = shadow_volume(inst, light, floor=-1.0)
    assert vol.shape == (2 * 6 + 2 * 6, 3, 4) and np.all(vol[..., 3] == 1.0)
    assert vol[..., 1].min() == pytest.approx(-1.0)
    edges = _closed_counts(vol)
    assert all(n == 1 for n in edges.values())
    assert all(edges.get((b, a)) == 1 for a, b in edges)
    # outward: the signed volume (divergence theorem) is positive, and it is the prism
    # the sun sweeps: the box's silhouette area × the vertical drop, for a directional sun
    p = vol[..., :3].astype(np.float64)
    signed = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert signed > 0
    # the sun's sweep of the unit box down to y = −1 (a drop of 3 to 4): the box plus the
    # prism below its lit faces' projection — bounded below by box + footprint·3
    assert signed > 1.0 + 3.0
    with pytest.raises(InvalidParameterError, match="above the horizon"):
        shadow_volume(inst, (0.0, -1.0, 0.0), floor=0.0)
    with pytest.raises(InvalidParameterError, match="finite"):
        shadow_volume(inst, light, floor=float("nan"))
