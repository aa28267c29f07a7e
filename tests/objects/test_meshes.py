"""The built-in meshes: real-world sizes, flat shading, outward winding, closed parts,
material-like linear colours, deterministic bytes."""

import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.objects import BUILTIN_NAMES, builtin_mesh, builtin_meshes
from terrascape.objects import meshes as meshes_module


def test_every_kind_is_built():
    ms = builtin_meshes()
    assert list(ms) == list(BUILTIN_NAMES)
    assert {"conifer", "broadleaf", "bush", "rock", "boulder", "house", "hall"} <= set(ms)
    for name, m in ms.items():
        assert m.name == name and 20 <= m.triangles <= 400


@pytest.mark.parametrize(("name", "lo", "hi"), [
    ("conifer", (5, 12, 5), (8, 25, 8)),
    ("broadleaf", (6, 8, 6), (10, 25, 10)),
    ("bush", (1.5, 1.0, 1.5), (4, 2.5, 4)),
    ("rock", (1.0, 0.7, 1.0), (2.5, 1.5, 2.5)),
    ("boulder", (2.5, 1.5, 2.5), (5, 3.5, 5)),
    ("house", (9, 7, 7), (12, 10, 10)),   # x, height with foundation, z
    ("hall", (20, 12, 12), (26, 18, 18)),
])
def test_sizes_are_metres(name, lo, hi):
    m = builtin_mesh(name)
    a, b = m.bounds
    size = b - a
    assert np.all(size >= lo) and np.all(size <= hi), (name, size)
    top = float(b[1])
    assert top > 0.3  # stands up from its foot
    # the foot is at the origin: centred in x/z, nothing but foundations/roots far below
    assert abs(float(a[0] + b[0])) / 2 < 0.6 and abs(float(a[2] + b[2])) / 2 < 0.6
    assert float(a[1]) >= -meshes_module.FOUNDATION_DEPTH - 1e-6


def test_house_dimensions_and_roof():
    m = builtin_mesh("house")
    b = m.bounds[1]
    assert 6.5 <= b[1] <= 8.0  # the chimney tops the 7 m ridge
    # roof faces: tile red (r clearly above g and b), some of them sloped
    red = (m.colors[:, 0] > 2.5 * m.colors[:, 1]) & (m.colors[:, 0] > 0.2)
    ny = m.normals[red][:, 1]
    assert red.sum() >= 12 and np.any((ny > 0.4) & (ny < 0.95))


def test_flat_shaded_outward_normals():
    for m in builtin_meshes().values():
        tri = m.positions[m.indices].astype(np.float64)
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area = np.linalg.norm(n, axis=1)
        assert np.all(area > 1e-8), m.name
        n /= area[:, None]
        for k in range(3):  # every corner carries its triangle's normal (counter-clockwise)
            np.testing.assert_allclose(m.normals[m.indices[:, k]], n, atol=1e-5)
        # closed and outward: the signed volume (divergence theorem) is positive
        vol = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
        assert vol > 0, m.name


def _weld(m):
    p = np.round(m.positions.astype(np.float64), 5)
    _, inverse = np.unique(p, axis=0, return_inverse=True)
    return inverse.reshape(-1)[m.indices]


def test_every_edge_has_an_opposite_twin():
    """Closed parts (what shadow volumes need): welded, each directed edge a→b appears once
    and b→a once."""
    for m in builtin_meshes().values():
        t = _weld(m)
        edges = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        fwd = {tuple(e) for e in edges}
        assert len(fwd) == len(edges), f"{m.name}: a directed edge twice"
        assert all((b, a) in fwd for a, b in fwd), f"{m.name}: an open edge"


def test_colours_look_like_their_materials():
    ms = builtin_meshes()
    for m in ms.values():
        assert m.colors.min() >= 0 and m.colors.max() <= 1
    def mean(name, mask=None):
        c = ms[name].colors.astype(np.float64)
        return c.mean(axis=0) if mask is None else c[mask(c)].mean(axis=0)
    foliage = mean("conifer", lambda c: c[:, 1] > c[:, 0])
    assert foliage[1] > foliage[0] and foliage[1] > foliage[2]  # green
    bark = mean("conifer", lambda c: c[:, 0] > c[:, 1])
    assert bark[0] > bark[1] > bark[2]  # brown
    stone = mean("rock")
    assert np.ptp(stone) < 0.05 and 0.1 < stone.mean() < 0.4  # grey
    plaster = mean("house", lambda c: c.mean(axis=1) > 0.4)
    assert plaster.min() > 0.4  # light walls


def test_deterministic_and_unknown_name():
    meshes_module._CACHE.clear()
    a = meshes_module.conifer()
    b = meshes_module.conifer()
    assert a.positions.tobytes() == b.positions.tobytes()
    assert a.colors.tobytes() == b.colors.tobytes()
    with pytest.raises(InvalidParameterError, match=r"unknown built-in mesh 'palm'.*conifer"):
        builtin_mesh("palm")


def test_cli_writes_the_models_for_other_readers(tmp_path):
    import trimesh

    from terrascape.cli import run_app

    out = tmp_path / "models.glb"
    assert run_app(["objects", "meshes", str(out)]) == 0
    scene = trimesh.load(out, force="scene")
    ms = builtin_meshes()
    assert set(scene.geometry) == set(ms)
    for name, geom in scene.geometry.items():
        np.testing.assert_allclose(np.sort(geom.vertices, axis=0),
                                   np.sort(ms[name].positions, axis=0), atol=1e-6)
    assert run_app(["objects", "meshes", str(out)]) == 2  # exists: needs --force
    assert run_app(["objects", "meshes", str(tmp_path / "m.obj")]) == 2
