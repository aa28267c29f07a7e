import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.relief.fields import natural_field
from terrascape.relief.prewarp import (
    prewarp,
    prewarp_coefficients,
    relief_texture_image,
    sample_bilinear,
)
from terrascape.relief.reference import ReliefQuad, quad_entry, reference_image

QUAD = ReliefQuad.centred(depth=0.1)
CAM = Camera.orbit((0, 0, 0), 30, 40, 2.0, aspect=1.0, fov_y=40)


def test_coefficients_match_oliveiras_cross_product_form():
    co = prewarp_coefficients(QUAD, CAM.eye)
    basis = QUAD.uvd_basis(CAM.eye)
    a, b, f = basis[:, 0], basis[:, 1], basis[:, 2]
    c = np.asarray(QUAD.origin) - CAM.eye  # source origin minus target centre
    assert co.k1 == pytest.approx(f @ np.cross(b, c) / (a @ np.cross(b, c)))
    assert co.k2 == pytest.approx(f @ np.cross(c, a) / (b @ np.cross(c, a)))
    assert co.k3 == pytest.approx(f @ np.cross(a, b) / (c @ np.cross(a, b)))
    assert co.k3 > 0  # relief below the face: 1 + k3·d never vanishes


def test_flat_displacement_is_plain_texture_mapping():
    rng = np.random.default_rng(0)
    tex = rng.random((32, 32, 3))
    warped, covered = prewarp(tex, np.zeros((32, 32)), prewarp_coefficients(QUAD, CAM.eye))
    assert covered.all()
    np.testing.assert_array_equal(warped, tex)
    img = relief_texture_image(tex, np.zeros((32, 32)), QUAD, CAM, 24, 24)
    uv0, _, valid = quad_entry(QUAD, CAM, 24, 24)
    plain = sample_bilinear(tex, uv0)
    np.testing.assert_allclose(img[valid], plain[valid], atol=1e-12)


@pytest.mark.parametrize("c", [0.3, 1.0])
def test_constant_displacement_is_a_shifted_plane(c):
    # Every texel slides to u_i = (u + k1·c)/(1 + k3·c): the warped texture at u_i is the
    # source at u = u_i·(1 + k3·c) − k1·c (bilinear between the neighbouring texels).
    n = 48
    rng = np.random.default_rng(1)
    tex = rng.random((n, n, 2))
    co = prewarp_coefficients(QUAD, CAM.eye)
    warped, covered = prewarp(tex, np.full((n, n), c), co)
    assert covered.all()
    centres = (np.arange(n) + 0.5) / n
    uu, vv = np.meshgrid(centres, centres)
    src = np.stack([uu * (1 + co.k3 * c) - co.k1 * c, vv * (1 + co.k3 * c) - co.k2 * c], -1)
    np.testing.assert_allclose(warped, sample_bilinear(tex, src, wrap=True), atol=1e-6)
    # And texture-mapping the result shows exactly the plane c·depth below the quad: the
    # texel seen at each pixel is the reference hit point.
    ident = np.stack(np.meshgrid(centres, centres), -1)
    img = relief_texture_image(ident, np.full((n, n), c), QUAD, CAM, 32, 32)
    ref = reference_image(np.full((n, n), 1.0 - c), QUAD, CAM, 32, 32)
    # Keep away from the identity texture's wrap seam (source and warped coordinates).
    margin = 0.5 - 1.5 / n
    inner = ref.valid & (np.abs(ref.uv - 0.5) < margin).all(-1)
    inner &= (np.abs(ref.uv0 - 0.5) < margin).all(-1)
    assert inner.sum() > 100
    np.testing.assert_allclose(img[inner], ref.uv[inner], atol=1e-6)


def test_occlusion_order_and_agreement_with_exact_reference():
    n = 64
    h = natural_field(n, seed=4)
    centres = (np.arange(n) + 0.5) / n
    ident = np.stack(np.meshgrid(centres, centres), -1)
    img = relief_texture_image(ident, 1.0 - h, QUAD, CAM, 48, 48)
    ref = reference_image(h, QUAD, CAM, 48, 48)
    v = ref.valid & np.isfinite(img).all(-1)
    d = np.abs(img - np.mod(ref.uv, 1.0))
    err = np.hypot(*np.minimum(d, 1 - d).transpose(2, 0, 1))[v] * n
    # Smooth field: the separable warp + linear reconstruction is within a texel.
    assert np.median(err) < 0.15
    assert np.percentile(err, 95) < 1.0


def test_prewarp_validation():
    co = prewarp_coefficients(QUAD, CAM.eye)
    with pytest.raises(InvalidParameterError, match=r"\[0, 1\]"):
        prewarp(np.zeros((4, 4)), np.full((4, 4), 1.5), co)
    with pytest.raises(InvalidParameterError, match="matching"):
        prewarp(np.zeros((4, 5)), np.zeros((4, 4)), co)
    with pytest.raises(InvalidParameterError, match="untiled"):
        prewarp_coefficients(ReliefQuad(uv_scale=(2, 2)), CAM.eye)
