import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.prewarp import sample_bilinear
from terrascape.relief.reference import (
    ReliefQuad,
    quad_entry,
    reference_image,
    shadow_exact,
    trace_exact,
)


def _dense_march(heights, uv0, ds, n=20000):
    s = np.linspace(0.0, 1.0, n + 1)
    pts = uv0[None, :] + s[:, None] * ds[None, :]
    f = s - (1.0 - sample_bilinear(heights, pts, wrap=True))
    return s[int(np.argmax(f >= 0))]


def test_constant_fields_hit_at_their_depth():
    rng = np.random.default_rng(0)
    uv0 = rng.uniform(0, 1, (50, 2))
    ds = rng.normal(0, 0.3, (50, 2))
    for h in (1.0, 0.0, 0.35):
        uv, s = trace_exact(np.full((16, 16), h), uv0, ds)
        np.testing.assert_allclose(s, 1.0 - h, atol=1e-7)
        np.testing.assert_allclose(uv, uv0 + s[:, None] * ds, atol=1e-12)


def test_linear_ramp_matches_the_analytic_intersection():
    # depth = a + b·x (x in texel-centre units) inside the texture, so the ray
    # s = a + b·(x0 + s·dx) hits at s = (a + b·x0)/(1 − b·dx).
    n = 64
    a, b = 0.2, 0.01
    depth = np.tile(a + b * np.arange(n), (n, 1))
    uv0 = np.array([[20.3 / n, 0.5], [40.7 / n, 0.25]])
    ds = np.array([[3.0 / n, 0.1], [-5.0 / n, 0.0]])
    _, s = trace_exact(1.0 - depth, uv0, ds)
    x0 = uv0[:, 0] * n - 0.5
    dx = ds[:, 0] * n
    np.testing.assert_allclose(s, (a + b * x0) / (1 - b * dx), atol=1e-7)


def test_matches_dense_march_on_natural_field_and_finds_thin_walls():
    h = natural_field(32, seed=2)
    rng = np.random.default_rng(1)
    uv0 = rng.uniform(0, 1, (20, 2))
    ds = rng.normal(0, 0.2, (20, 2))
    _, s = trace_exact(h, uv0, ds)
    dense = np.array([_dense_march(h, u, d) for u, d in zip(uv0, ds, strict=True)])
    # The dense march can only be late, by at most one of its steps.
    assert np.all(s <= dense + 1e-9) and np.all(dense - s < 1e-4 + 1e-9)
    # A 1-texel wall between deep streets: a grazing ray that clips its tip is caught.
    wall = np.zeros((8, 8))
    wall[:, 4] = 0.8  # depth 0.2 at the tip, a tent of bilinear slopes around it
    _uv, s = trace_exact(wall, np.array([[6.5 / 8, 0.5]]), np.array([[-10.0 / 8, 0.0]]))
    # The ray x = 6 − 10·s (texel units) meets the tent's right slope
    # depth = 0.2 + 0.8·(x − 4) at s = 0.2 + 0.8·(2 − 10·s), i.e. s = 1.8 / 9.
    assert s[0] == pytest.approx(1.8 / 9.0, abs=1e-6)


def test_quad_entry_projects_back_to_the_pixel_centres():
    quad = ReliefQuad((-1, 0, -1), (2, 0, 0.3), (0.1, 0, 2), 0.1)
    cam = Camera.orbit((0, 0, 0), 40, 50, 3.0, aspect=1.0, fov_y=50)
    uv0, _ds, valid = quad_entry(quad, cam, 16, 16)
    assert valid.sum() > 50
    o = np.asarray(quad.origin)
    world = o + uv0[..., :1] * np.asarray(quad.u_axis) + uv0[..., 1:] * np.asarray(quad.v_axis)
    px = cam.project(world[valid], (16, 16))
    rows, cols = np.nonzero(valid)
    np.testing.assert_allclose(px[:, 0], cols + 0.5, atol=1e-6)
    np.testing.assert_allclose(px[:, 1], 16 - (rows + 0.5), atol=1e-6)  # row 0 = bottom


def test_shadow_exact_behind_a_wall_and_none_on_flat():
    flat = np.full((16, 16), 0.5)
    uv = np.array([[0.3, 0.5]])
    assert not shadow_exact(flat, uv, np.array([0.5]), np.array([0.5, 0.0]))[0]
    # Street (depth 1) with a full-height wall 3 texels toward the light (+u).
    f = np.zeros((16, 16))
    f[:, 9] = 1.0
    p = np.array([[6.5 / 16, 0.5]])
    # Light rising 1 depth unit per 8 texels (0.5 UV): the wall top (depth 0) is 2.5
    # texels away; the ray is at depth 1 − 2.5/8 > 0 there → shadowed.
    assert shadow_exact(f, p, np.array([1.0]), np.array([0.5, 0.0]))[0]
    # Light from the other side: nothing in the way.
    assert not shadow_exact(f, p, np.array([1.0]), np.array([-0.5, 0.0]))[0]
    # A steep light (1 texel of travel per unit depth) from the wall side passes above it.
    assert not shadow_exact(f, p, np.array([1.0]), np.array([1 / 16, 0.0]))[0]


def test_reference_image_and_validation():
    h = city_field(64, block=16)
    quad = ReliefQuad.centred(depth=0.1)
    cam = Camera.orbit((0, 0, 0), 10, 45, 1.5, aspect=1.0, fov_y=45)
    ref = reference_image(h, quad, cam, 24, 24, light_dir=(0.3, 0.7, 0.1))
    v = ref.valid
    assert v.any() and np.isnan(ref.depth[~v]).all()
    assert (ref.depth[v] >= 0).all() and (ref.depth[v] <= 1).all()
    assert ref.shadow.dtype == bool and not ref.shadow[~v].any()
    with pytest.raises(InvalidParameterError, match=r"\[0, 1\]"):
        trace_exact(np.full((4, 4), 2.0), np.zeros((1, 2)), np.zeros((1, 2)))
    with pytest.raises(InvalidParameterError, match="span a plane"):
        ReliefQuad((0, 0, 0), (1, 0, 0), (2, 0, 0))
    with pytest.raises(InvalidParameterError, match="below"):
        reference_image(h, quad, cam, 4, 4, light_dir=(0, -1, 0))
