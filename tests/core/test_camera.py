import math

import numpy as np
import pytest

from terrascape.camera import Camera, angles_from_direction, frame_terrain
from terrascape.errors import InvalidParameterError


def test_look_at_points_forward_at_target():
    cam = Camera.look_at((0, 10, 0), (10, 0, -10))
    d = np.array([10, -10, -10]) / math.sqrt(300)
    assert np.allclose(cam.forward, d, atol=1e-9)


def test_basis_is_orthonormal_and_right_handed():
    cam = Camera(position=(1, 2, 3), yaw=37, pitch=-20)
    f, r, u = cam.forward, cam.right, cam.up
    for v in (f, r, u):
        assert np.isclose(np.linalg.norm(v), 1)
    assert abs(f @ r) < 1e-12 and abs(f @ u) < 1e-12 and abs(r @ u) < 1e-12
    # OpenGL eye space: right × up = -forward (camera looks down -Z)
    assert np.allclose(np.cross(r, u), -f)
    assert u[1] > 0


def test_view_matrix_maps_target_onto_negative_z_axis():
    cam = Camera.look_at((5, 5, 5), (0, 0, 0))
    p = cam.view_matrix() @ np.array([0, 0, 0, 1.0])
    assert np.allclose(p[:2], 0, atol=1e-9)
    assert np.isclose(p[2], -math.sqrt(75))


def test_projection_maps_near_and_far_to_ndc_bounds():
    cam = Camera(near=0.5, far=100)
    proj = cam.projection_matrix()
    for z, ndc in ((-0.5, -1), (-100, 1)):
        c = proj @ np.array([0, 0, z, 1.0])
        assert np.isclose(c[2] / c[3], ndc)


def test_straight_down_and_up_give_finite_matrices():
    for target in ((0, -10, 0), (0, 10, 0)):
        cam = Camera.look_at((0, 0, 0), target)
        assert np.isfinite(cam.view_projection()).all()
        assert abs(cam.pitch) == pytest.approx(89.9)


def test_frustum_planes_classify_points():
    cam = Camera.look_at((0, 0, 0), (0, 0, -1), fov_y=90, aspect=1, near=1, far=100)
    planes = cam.frustum_planes()
    inside = np.array([0, 0, -50, 1.0])
    outside_left = np.array([-60, 0, -50, 1.0])  # |x| > |z| at 90° fov
    behind = np.array([0, 0, 5, 1.0])
    assert (planes @ inside >= 0).all()
    assert (planes @ outside_left < 0).any()
    assert (planes @ behind < 0).any()
    # plane normals are unit length
    assert np.allclose(np.linalg.norm(planes[:, :3], axis=1), 1)


def test_project_centre_pixel():
    cam = Camera.look_at((0, 0, 10), (0, 0, 0), aspect=2)
    px = cam.project([[0, 0, 0]], (200, 100))[0]
    assert np.allclose(px, [100, 50, 10])


def test_angles_roundtrip():
    yaw, pitch = angles_from_direction([1, 0, 0])
    assert (yaw, pitch) == pytest.approx((90, 0))
    yaw, pitch = angles_from_direction([0, 1, -1])
    assert (yaw, pitch) == pytest.approx((0, 45))


def test_frame_terrain_sees_all_corners():
    cam = frame_terrain((4096.0, 2048.0), (0.0, 800.0), aspect=16 / 9)
    planes = cam.frustum_planes()
    for x in (0, 4096):
        for z in (0, 2048):
            for y in (0, 800):
                assert (planes @ np.array([x, y, z, 1.0]) >= 0).all()


@pytest.mark.parametrize(
    "kwargs",
    [dict(fov_y=0), dict(near=0), dict(near=10, far=5), dict(position=(0, float("nan"), 0))],
)
def test_bad_camera_parameters_raise(kwargs):
    with pytest.raises(InvalidParameterError):
        Camera(**kwargs)


def test_look_at_same_point_raises():
    with pytest.raises(InvalidParameterError):
        Camera.look_at((1, 1, 1), (1, 1, 1))


def test_infinite_far_puts_points_at_infinity_inside_the_depth_range():
    from terrascape.camera import INFINITE_FAR_EPSILON

    cam = Camera.look_at((0, 10, 30), (0, 0, 0), near=0.5, far=100.0, infinite_far=True)
    vp = cam.view_projection()
    # a direction (w = 0) in front of the camera: NDC depth 1 − ε, not clipped
    for d in ([0.0, -10.0, -30.0, 0.0], [3.0, -8.0, -30.0, 0.0]):
        clip = vp @ np.array(d)
        assert clip[3] > 0
        assert clip[2] / clip[3] == pytest.approx(1.0 - INFINITE_FAR_EPSILON, abs=1e-12)
    # finite points: the same x, y as the finite camera; depth the limit far → ∞
    p = np.array([2.0, 1.0, -5.0, 1.0])
    finite = Camera.look_at((0, 10, 30), (0, 0, 0), near=0.5, far=1e9)
    a, b = vp @ p, finite.view_projection() @ p
    np.testing.assert_allclose(a[:2] / a[3], b[:2] / b[3], rtol=1e-12)
    assert a[2] / a[3] == pytest.approx(b[2] / b[3], abs=1e-6)


@pytest.mark.parametrize("infinite", [False, True])
def test_window_depth_and_eye_distance_are_inverse(infinite):
    cam = Camera(near=0.5, far=100.0, infinite_far=infinite)
    s = np.array([0.6, 1.0, 7.0, 99.0])  # beyond the near plane (depth 0)
    d = cam.window_depth(s)
    assert np.all((d > 0) & (d < 1)) and np.all(np.diff(d) > 0)
    np.testing.assert_allclose(cam.eye_distance(d), s, rtol=1e-9)
    # against the matrix: window depth of a point s in front of the eye
    clip = cam.projection_matrix() @ np.array([0.0, 0.0, -7.0, 1.0])
    assert d[2] == pytest.approx(clip[2] / clip[3] * 0.5 + 0.5, abs=1e-12)
    assert cam.eye_distance(1.0) == np.inf and cam.window_depth(np.inf) == 1.0
