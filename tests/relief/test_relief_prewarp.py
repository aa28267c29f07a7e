import math

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


def _reference_warp_line(x, vals, ok, e, m):
    # Seed §2.4.5 as written: painter's occlusion-compatible order (left sweep →, right
    # sweep ←, the epipole's span last), every span drawn in full, later writes win.
    out = np.zeros((m, vals.shape[1]))
    written = np.zeros(m, dtype=bool)
    n = len(x)
    ce = min(max(math.floor(e), -1), n - 1)
    order = [*range(0, ce), *range(n - 2, ce, -1), *([ce] if 0 <= ce < n - 1 else [])]
    for i in order:
        if ok[i] and ok[i + 1] and x[i + 1] > x[i]:
            inv = 1.0 / (x[i + 1] - x[i])
            for j in range(max(math.ceil(x[i]), 0), min(math.floor(x[i + 1]), m - 1) + 1):
                out[j] = vals[i] + (vals[i + 1] - vals[i]) * ((j - x[i]) * inv)
                written[j] = True
    for i in range(n):
        j = math.floor(x[i] + 0.5)
        if ok[i] and abs(x[i] - j) < 1e-9 and 0 <= j < m and not written[j]:
            out[j] = vals[i]
            written[j] = True
    return out, written


def _reference_prewarp(colour, disp, co):
    """Serial, unoptimised two-pass pre-warp with generous symmetric wrapped margins."""
    rows, cols, nc = colour.shape
    k1p, k2p, k3 = co.k1 * cols, co.k2 * rows, co.k3
    eu, ev = co.epipole[0] * cols, co.epipole[1] * rows
    # Texels slide toward the epipole by at most k3·|E − p|: anything farther out lands
    # outside the image, so extra margin cannot change the result.
    mx = math.ceil(k3 * (max(abs(eu), abs(eu - cols)) + cols)) + 4
    my = math.ceil(k3 * (max(abs(ev), abs(ev - rows)) + rows)) + 4
    inter = np.zeros((rows + 2 * my, cols, nc + 1))
    inter_ok = np.zeros((rows + 2 * my, cols), dtype=bool)
    for rr in range(rows + 2 * my):
        r = rr - my
        cs = np.arange(-mx, cols + mx)
        d = disp[r % rows, cs % cols]
        w = 1.0 + k3 * d
        x = (cs + 0.5 + k1p * d) / w - 0.5
        target_row = (r + 0.5 + k2p * d) / w - 0.5
        vals = np.concatenate([colour[r % rows, cs % cols], target_row[:, None]], 1)
        inter[rr], inter_ok[rr] = _reference_warp_line(
            x, vals, np.ones(len(x), bool), eu - 0.5 + mx, cols
        )
    result = np.zeros((rows, cols, nc))
    covered = np.zeros((rows, cols), dtype=bool)
    for j in range(cols):
        result[:, j], covered[:, j] = _reference_warp_line(
            inter[:, j, nc], inter[:, j, :nc], inter_ok[:, j], ev - 0.5 + my, rows
        )
    return result, covered


@pytest.mark.parametrize(
    ("eye", "shape"),
    [
        ((0.1, 0.9, -0.2), (12, 10)),  # epipole inside the texture: margins on all sides
        ((1.2, 0.25, -0.9), (10, 14)),  # grazing, epipole outside: one-sided margins
        ((-0.3, 0.12, 1.4), (9, 9)),  # very grazing, heavy folds and hidden walls
    ],
)
def test_prewarp_matches_serial_painters_reference(eye, shape):
    # The kernels walk the painter's order backwards (first writer wins), use one-sided
    # margins and run rows / columns in parallel; none of that may change a single byte.
    rng = np.random.default_rng(sum(shape))
    quad = ReliefQuad((-0.5, 0, -0.5), (1, 0, 0), (0, 0, 1), 0.1)
    co = prewarp_coefficients(quad, np.array(eye))
    disp = np.round(rng.random(shape) * 3) / 3  # plateaus: walls, folds, exact pixel hits
    disp[rng.random(shape) < 0.3] = rng.random()
    disp = disp.astype(np.float32).astype(np.float64)  # prewarp stores d as float32 first
    colour = rng.random((*shape, 3))
    img, covered = prewarp(colour, disp, co)
    ref, ref_covered = _reference_prewarp(colour, disp, co)
    np.testing.assert_array_equal(covered, ref_covered)
    np.testing.assert_array_equal(img, ref)


def test_prewarp_is_deterministic_across_calls_and_thread_counts():
    import numba

    n = 128
    h = natural_field(n, seed=2)
    colour = np.random.default_rng(3).random((n, n, 3))
    quad = ReliefQuad((-0.5, 0, -0.5), (1, 0, 0), (0, 0, 1), 0.1)
    co = prewarp_coefficients(quad, np.array([0.9, 0.25, -0.6]))  # grazing: big margins
    a, ca = prewarp(colour, 1.0 - h, co)
    b, cb = prewarp(colour, 1.0 - h, co)
    assert a.tobytes() == b.tobytes() and np.array_equal(ca, cb)
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        c, cc = prewarp(colour, 1.0 - h, co)
    finally:
        numba.set_num_threads(threads)
    assert a.tobytes() == c.tobytes() and np.array_equal(ca, cc)


def test_warp_line_matches_painters_order_on_adversarial_lines():
    # Random target positions (folds everywhere, gaps, samples on exact pixel centres and
    # the epipole anywhere) hit the cases the city texture rarely does: a hidden pixel the
    # reversed order must skip, and pixels between two covered runs it must still draw.
    from terrascape.relief.prewarp import _warp_line

    rng = np.random.default_rng(11)
    for trial in range(300):
        n, m = int(rng.integers(2, 40)), int(rng.integers(1, 30))
        steps = rng.normal(0.7, 1.5, n)
        x = [rng.uniform(-4, m + 4, n), np.cumsum(steps) - 2,
             np.round(np.cumsum(steps) * 2) / 2 - 2][trial % 3]
        vals = rng.random((n, 3))
        ok = (rng.random(n) < rng.uniform(0.6, 1.0)).astype(np.uint8)
        e = rng.uniform(-5, n + 5)
        out = np.full((m, 3), np.nan)
        written = np.full(m, 7, dtype=np.uint8)  # the kernel clears both itself
        _warp_line(x, vals, ok, e, out, written)
        ref, ref_written = _reference_warp_line(x, vals, ok, e, m)
        np.testing.assert_array_equal(written.astype(bool), ref_written)
        np.testing.assert_array_equal(out, ref)
