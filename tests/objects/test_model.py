import numpy as np
import pytest

from terrascape.errors import InvalidParameterError
from terrascape.objects import Instances, ObjectMesh


def _tetra(name="t"):
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [0, 1, 0]], np.float32)
    i = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]])
    return ObjectMesh(name, p, np.tile([0, 1, 0], (4, 1)), np.ones((4, 3)), i)


def test_mesh_validates():
    m = _tetra()
    assert m.triangles == 4 and m.indices.dtype == np.uint32
    with pytest.raises(InvalidParameterError, match="past"):
        ObjectMesh("x", m.positions, m.normals, m.colors, [[0, 1, 9]])
    with pytest.raises(InvalidParameterError, match="finite"):
        ObjectMesh("x", [[np.nan, 0, 0]], [[0, 1, 0]], [[1, 1, 1]], [[0, 0, 0]])


def test_matrices_scale_yaw_translate():
    inst = Instances((_tetra(),), [0], [[10, 5, 20]], [2.0], [np.pi / 2])
    m = inst.matrices()[0].astype(np.float64)
    # +X rotated a quarter turn counter-clockwise seen from above goes to −Z
    x = m @ [1, 0, 0, 1]
    np.testing.assert_allclose(x[:3], [10, 5, 18], atol=1e-5)
    tri = inst.world_triangles()
    assert tri.shape == (4, 3, 3)
    np.testing.assert_allclose(tri[1, 2], [10, 7, 20], atol=1e-5)  # apex lifted by scale 2


def test_instances_validate():
    with pytest.raises(InvalidParameterError, match="index"):
        Instances((_tetra(),), [1], [[0, 0, 0]], [1], [0])
    with pytest.raises(InvalidParameterError, match="> 0"):
        Instances((_tetra(),), [0], [[0, 0, 0]], [0], [0])
    empty = Instances((_tetra(),), np.zeros(0, int), np.zeros((0, 3)), [], [])
    assert len(empty) == 0 and empty.world_triangles().shape == (0, 3, 3)
