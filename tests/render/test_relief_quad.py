"""Relief shaders vs the exact CPU reference and vs their formulas (small framebuffers)."""

import warnings

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import InvalidParameterError
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.prewarp import sample_bilinear
from terrascape.relief.reference import ReliefQuad, quad_entry, reference_image

pytestmark = pytest.mark.gl

N = 64  # relief texture size
FB = 96  # framebuffer size
TILED = ReliefQuad((-2, 0, -2), (4, 0, 0), (0, 0, 4), 0.1, (4.0, 4.0))


def _camera(theta, azimuth=30.0):
    """Camera looking at the quad centre from `theta` degrees off the normal."""
    return Camera.orbit((0, 0, 0), azimuth, 90.0 - theta, 2.0, aspect=1.0, fov_y=40)


@pytest.fixture(scope="module")
def natural():
    return natural_field(N, seed=7)


@pytest.fixture(scope="module")
def city():
    return city_field(N, seed=7, block=16, street=4)


@pytest.fixture(scope="module")
def renderers(gl_ctx, natural, city):
    from terrascape.render.relief_quad import ReliefQuadRenderer

    made = {
        "natural": ReliefQuadRenderer(gl_ctx, natural, size=(FB, FB)),
        "city": ReliefQuadRenderer(gl_ctx, city, size=(FB, FB)),
    }
    yield made
    for r in made.values():
        r.release()


LIGHT = (0.8, 0.35, 0.2)


def _shadowed(renderer, cam, technique, settings=None, light=LIGHT):
    """Where ``technique`` draws self-shadow (R7) on the quad, as a bool (H, W) mask."""
    from terrascape.render.relief_quad import ReliefSettings

    st = (settings or ReliefSettings()).with_(shadows=True)
    out = renderer.render(TILED, cam, technique, settings=st, output="shadow", light_dir=light)
    return out[..., 0] > 0.5


def _errors(out, ref):
    v = ref.valid
    e = np.hypot(*(out[..., :2] - ref.uv).transpose(2, 0, 1)) * N
    return e[v], (out[..., 2] - ref.depth)[v]


@pytest.mark.parametrize(
    ("technique", "theta", "p95", "mean"),
    [
        ("relief", 30, 0.05, 0.02),
        ("interval", 30, 0.05, 0.02),
        ("minmax", 30, 0.01, 0.005),
        ("minmax", 75, 0.01, 0.005),
        ("cone", 30, 0.05, 0.02),
        ("pom", 30, 0.3, 0.1),
        ("steep", 30, 0.6, 0.3),
    ],
)
def test_traced_hits_match_the_exact_reference_on_natural(
    renderers, natural, technique, theta, p95, mean
):
    from terrascape.render.relief_quad import ReliefSettings

    cam = _camera(theta)
    out = renderers["natural"].render(TILED, cam, technique, settings=ReliefSettings())
    assert renderers["natural"].last_technique == technique
    ref = reference_image(natural, TILED, cam, FB, FB)
    err, _ = _errors(out, ref)
    assert err.size > 0.5 * FB * FB
    assert np.percentile(err, 95) <= p95
    assert err.mean() <= mean


def test_default_relief_mode_clearance_steps(renderers, natural):
    # ReliefSettings() marches clearance-scaled linear steps (+ 4 binary): within the seed's
    # 18 fetches and the p95 bound, and fewer skipped crests than equal 16+8 steps at grazing
    # angles (Policarpo 2005's linear search with sample placement following the clearance).
    from terrascape.render.relief_quad import ReliefSettings

    fixed = ReliefSettings(march="fixed", linear_steps=16, binary_steps=8)
    assert ReliefSettings().march == "clearance"
    for theta in (30, 70, 80):
        cam = _camera(theta)
        ref = reference_image(natural, TILED, cam, FB, FB)
        out = renderers["natural"].render(TILED, cam, "relief")
        err, _ = _errors(out, ref)
        fetches = out[..., 3][ref.valid].mean()
        assert np.percentile(err, 95) <= 0.06
        assert fetches <= 14.0
        if theta == 80:
            base = renderers["natural"].render(TILED, cam, "relief", settings=fixed)
            base_err, _ = _errors(base, ref)
            assert (err > 1).mean() <= 0.008
            assert (err > 1).mean() < 0.6 * (base_err > 1).mean()
            assert fetches < base[..., 3][ref.valid].mean() - 3.0


@pytest.mark.parametrize("theta", [30, 60, 80])
def test_minmax_is_exact_on_thin_city_walls(renderers, city, theta):
    cam = _camera(theta, azimuth=20)
    out = renderers["city"].render(TILED, cam, "minmax")
    ref = reference_image(city, TILED, cam, FB, FB)
    err, ddepth = _errors(out, ref)
    assert np.percentile(err, 95) <= 0.05
    assert (err > 1).mean() < 0.002  # knife-edge pixels only
    # Relief 16+8 on the same view skips thin walls (deeper hits) far more often.
    rel = renderers["city"].render(TILED, cam, "relief")
    _rerr, rdepth = _errors(rel, ref)
    assert (rdepth > 1e-3).mean() > (ddepth > 1e-3).mean()


def test_parallax_at_grazing_angles_is_documented_loose(renderers, natural):
    # Parallax has no search: at 30° it stays within a few texels of the true hit on a
    # smooth field, at 75° its error grows (the seed's "flattening at small angles").
    errs = {}
    for theta in (30, 75):
        cam = _camera(theta)
        out = renderers["natural"].render(TILED, cam, "parallax")
        ref = reference_image(natural, TILED, cam, FB, FB)
        errs[theta] = np.percentile(_errors(out, ref)[0], 95)
    assert errs[30] < 3.0
    assert errs[75] > errs[30]


def _parallax_numpy(heights, uv0, ds, depth, limited):
    h = sample_bilinear(heights, uv0, wrap=True)
    hs = depth * h - depth  # scale = depth, bias = −depth (the polygon is the top)
    V = np.concatenate([-ds, np.full((*ds.shape[:-1], 1), depth)], axis=-1)
    V /= np.linalg.norm(V, axis=-1, keepdims=True)
    off = V[..., :2] if limited else V[..., :2] / V[..., 2:]
    return uv0 + hs[..., None] * off


QUADS = {
    "plain": TILED,
    "rotated": ReliefQuad((-1.2, 0.4, -0.9), (2.3, 0.5, 0.9), (-0.8, 0.2, 2.2), 0.1),
    "mirrored": ReliefQuad((-1.5, 0, 1.5), (3, 0, 0), (0, 0, -3), 0.1, (2.0, 2.0)),
}


@pytest.mark.parametrize("quad_name", list(QUADS))
@pytest.mark.parametrize("technique", ["parallax", "offset_limiting"])
def test_parallax_formulas_pixel_by_pixel(renderers, natural, quad_name, technique):
    quad = QUADS[quad_name]
    cam = Camera.look_at((0.4, 1.6, 1.5), (0, 0.1, 0), aspect=1.0, fov_y=60)
    r = renderers["natural"]
    out = r.render(quad, cam, technique)
    plain = r.render(quad, cam, "plain")
    _, ds, valid = quad_entry(quad, cam, FB, FB)
    assert valid.mean() > 0.3
    uv0 = plain[..., :2].astype(np.float64)  # the GPU's own interpolated texcoords
    expect = _parallax_numpy(natural, uv0, ds, quad.depth, technique == "offset_limiting")
    err = np.abs(out[..., :2] - expect)[valid] * N
    assert err.max() <= 0.01
    # The offset is real (not the identity) and ≤ depth for offset limiting.
    shift = np.hypot(*(out[..., :2] - uv0)[valid].T)
    assert shift.max() > 0.01
    if technique == "offset_limiting":
        assert shift.max() <= quad.depth + 1e-6


def test_self_shadowing_against_exact(renderers, natural):
    from terrascape.render.relief_quad import ReliefSettings

    cam = _camera(45)
    ref = reference_image(natural, TILED, cam, FB, FB, light_dir=LIGHT)
    v = ref.valid
    assert 0.05 < ref.shadow[v].mean() < 0.95
    exact = _shadowed(renderers["natural"], cam, "minmax")
    relief = _shadowed(renderers["natural"], cam, "relief")
    assert (exact != ref.shadow)[v].mean() < 0.01
    assert (relief != ref.shadow)[v].mean() < 0.05
    off = renderers["natural"].render(TILED, cam, "relief", output="shadow",
                                      settings=ReliefSettings(shadows=False), light_dir=LIGHT)
    assert not off[..., 0].any()


def test_default_search_is_denser_on_a_field_with_walls(renderers, city):
    # ReliefSettings(linear_steps=None): the clearance march takes at most 1/32 of the ray
    # per step over the city (walls one or two texels thin), 1/16 elsewhere. Over the city it
    # skips fewer walls than the 16-step march, and its self-shadowing (R7) stays within the
    # issue's 10 % of the exact shadow at grazing angles, where the 16-step march is over.
    from terrascape.render.relief_quad import ReliefSettings

    assert renderers["city"].has_walls and not renderers["natural"].has_walls
    for theta in (60, 80):
        cam = _camera(theta)
        ref = reference_image(city, TILED, cam, FB, FB, light_dir=LIGHT)
        v = ref.valid
        results = {}
        for steps in (16, None):
            st = ReliefSettings(linear_steps=steps)
            hit = renderers["city"].render(TILED, cam, "relief", settings=st)
            shadow = _shadowed(renderers["city"], cam, "relief", st)
            results[steps] = (((hit[..., 2] - ref.depth)[v] > 0.01).mean(),
                              (shadow != ref.shadow)[v].mean(),
                              hit[..., 3][v].mean())
        skip16, dis16, fetch16 = results[16]
        skip, dis, fetch = results[None]
        assert skip <= 0.7 * skip16
        assert dis < dis16 and dis <= 0.10
        assert fetch <= 1.7 * fetch16
    assert dis16 > 0.10  # at 80°: the 16-step march misses the figure
    # Steep parallax / POM / interval march equal steps: the default count stays 16 on walls.
    for technique in ("pom", "interval"):
        default = renderers["city"].render(TILED, cam, technique)
        sixteen = renderers["city"].render(TILED, cam, technique,
                                           settings=ReliefSettings(linear_steps=16))
        assert np.array_equal(default, sixteen)


def test_linear_steps_default_resolution():
    from terrascape.render.relief_quad import (
        LINEAR_STEPS,
        WALL_LINEAR_STEPS,
        ReliefSettings,
    )

    st = ReliefSettings()
    assert st.linear_steps is None
    assert st.resolved_linear_steps(walls=False) == LINEAR_STEPS == 16
    assert st.resolved_linear_steps(walls=True) == WALL_LINEAR_STEPS == 32
    assert st.uniforms(0.1, walls=True)["u_linear_steps"] == 32
    assert st.uniforms(0.1)["u_linear_steps"] == 16
    # Only the clearance march is made denser; an explicit count always wins.
    assert ReliefSettings(march="fixed").resolved_linear_steps(walls=True) == 16
    assert ReliefSettings(march="angle").resolved_linear_steps(walls=True) == 16
    assert ReliefSettings(linear_steps=20).resolved_linear_steps(walls=True) == 20


@pytest.mark.parametrize(("field", "bound"), [("natural", 0.02), ("city", 0.06)])
def test_relief_shadow_march_matches_exact_shadow_at_its_own_hit(renderers, natural, city,
                                                                 field, bound):
    # The shadow march (R7) starts on the surface at the hit's uv and steps one texel of the
    # light ray: compared with the exact shadow of that same surface point it never shadows a
    # lit point (no self-shadowing from the search's depth error) and misses only light rays
    # that clip an edge by less than a step.
    from terrascape.relief.reference import light_slope, shadow_exact
    from terrascape.render.relief_quad import ReliefSettings

    heights = {"natural": natural, "city": city}[field]
    st = ReliefSettings(shadows=True)
    for theta in (45, 70):
        cam = _camera(theta)
        v = quad_entry(TILED, cam, FB, FB)[2]
        hit = renderers[field].render(TILED, cam, "relief", settings=st)
        mine = _shadowed(renderers[field], cam, "relief", st)
        uv = np.where(v[..., None], hit[..., :2].astype(np.float64), np.nan)
        surface = 1.0 - sample_bilinear(heights, np.nan_to_num(uv), wrap=True)
        exact = shadow_exact(heights, uv, np.where(v, surface, np.nan),
                             light_slope(TILED, cam.eye, LIGHT))
        assert 0.03 < exact[v].mean() < 0.9
        assert (mine != exact)[v].mean() <= bound
        assert (mine & ~exact)[v].mean() <= 0.001


@pytest.mark.parametrize("theta", [30, 70])
def test_minmax_shadow_is_exact_on_the_city(renderers, city, theta):
    # The exact hierarchical march toward the light (from level 0 up) agrees with
    # shadow_exact up to knife-edge pixels, thin walls included.
    cam = _camera(theta, azimuth=20)
    ref = reference_image(city, TILED, cam, FB, FB, light_dir=LIGHT)
    v = ref.valid
    assert 0.05 < ref.shadow[v].mean() < 0.95
    assert (_shadowed(renderers["city"], cam, "minmax") != ref.shadow)[v].mean() < 0.003


def test_runtime_uniforms_change_the_result(renderers, city):
    from terrascape.render.relief_quad import ReliefSettings

    cam = _camera(70)
    ref = reference_image(city, TILED, cam, FB, FB)
    coarse = renderers["city"].render(TILED, cam, "relief",
                                      settings=ReliefSettings(linear_steps=4))
    fine = renderers["city"].render(TILED, cam, "relief",
                                    settings=ReliefSettings(linear_steps=64))
    adaptive = renderers["city"].render(
        TILED, cam, "relief", settings=ReliefSettings(march="angle", step_texels=0.5)
    )
    e = {k: _errors(o, ref)[0].mean() for k, o in
         {"coarse": coarse, "fine": fine, "adaptive": adaptive}.items()}
    assert e["fine"] < e["coarse"] and e["adaptive"] < e["coarse"]
    # Fetches are counted: 64 linear steps cost more than 4.
    v = ref.valid
    assert fine[..., 3][v].mean() > coarse[..., 3][v].mean()


def test_colour_output_and_by_distance(renderers):
    from terrascape.render.relief_quad import ReliefSettings

    cam = _camera(50)
    img = renderers["natural"].render(TILED, cam, "relief", output="colour",
                                      settings=ReliefSettings(shadows=True))
    assert img[..., 3].max() == 1.0 and 0.05 < img[..., :3][img[..., 3] > 0].mean() < 1.0
    # By distance: bands far beyond the scene → relief everywhere; at 0 → plain everywhere.
    near = renderers["natural"].render(
        TILED, cam, "by_distance",
        settings=ReliefSettings(dist_relief=100.0, dist_parallax=200.0, dist_band=1.0))
    rel = renderers["natural"].render(TILED, cam, "relief")
    np.testing.assert_allclose(near[..., :3], rel[..., :3], atol=1e-6)
    far = renderers["natural"].render(
        TILED, cam, "by_distance",
        settings=ReliefSettings(dist_relief=0.0, dist_parallax=0.0, dist_band=0.01))
    plain = renderers["natural"].render(TILED, cam, "plain")
    np.testing.assert_allclose(far[..., :2], plain[..., :2], atol=1e-6)


def test_compile_failure_falls_back_to_plain_with_one_warning(renderers):
    from terrascape.render.relief_quad import ReliefFallbackWarning

    cam = _camera(40)
    r = renderers["natural"]
    forced = {"RELIEF_FORCE_COMPILE_ERROR": True}
    with pytest.warns(ReliefFallbackWarning, match="plain texturing"):
        out = r.render(TILED, cam, "relief", defines=forced)
    assert r.last_technique == "plain"
    np.testing.assert_array_equal(out, r.render(TILED, cam, "plain"))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # warned once only
        r.render(TILED, cam, "relief", defines=forced)


def test_bad_technique_and_settings():
    from terrascape.render.relief_quad import ReliefSettings, technique_id

    with pytest.raises(InvalidParameterError, match="unknown relief technique"):
        technique_id("bogus")
    with pytest.raises(InvalidParameterError, match="linear_steps"):
        ReliefSettings(linear_steps=0)
    with pytest.raises(InvalidParameterError, match="march"):
        ReliefSettings(march="sphere")
    assert ReliefSettings(march="angle").uniforms(0.1)["u_adaptive"] == 1
    assert ReliefSettings(march="fixed").uniforms(0.1)["u_adaptive"] == 0
    assert ReliefSettings().uniforms(0.1)["u_adaptive"] == 2


@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("theta", [30, 70, 80])
def test_minmax_is_exact_on_the_surface_an_integer_texture_samples(gl_ctx, theta, bits):
    """Packed 8/16-bit heights: the pyramid is built from the sampled codes, so the tracer
    stays exact against the exact hit of the quantised surface."""
    from terrascape.relief.fields import sampled_heights
    from terrascape.render.relief_quad import ReliefQuadRenderer

    field = natural_field(N, seed=11, beta=2.6)
    surface = sampled_heights(field, bits)
    r = ReliefQuadRenderer(gl_ctx, field, size=(FB, FB), bits=bits)
    try:
        np.testing.assert_array_equal(r.heights, surface)
        cam = _camera(theta)
        out = r.render(TILED, cam, "minmax")
        ref = reference_image(surface, TILED, cam, FB, FB)
        err, _ = _errors(out, ref)
        assert np.percentile(err, 95) <= 0.01
        assert (err > 1).mean() < 0.003
    finally:
        r.release()


def test_minmax_finds_one_texel_fences_that_linear_search_misses(gl_ctx):
    from terrascape.relief.fields import fence_field
    from terrascape.render.relief_quad import ReliefQuadRenderer, ReliefSettings

    fences = fence_field(N, seed=3, fences=10)
    r = ReliefQuadRenderer(gl_ctx, fences, size=(FB, FB))
    try:
        cam = _camera(75, azimuth=25)
        ref = reference_image(fences, TILED, cam, FB, FB)
        _, exact_depth = _errors(r.render(TILED, cam, "minmax"), ref)
        fixed = ReliefSettings(march="fixed", linear_steps=16, binary_steps=8)
        _, linear_depth = _errors(r.render(TILED, cam, "relief", settings=fixed), ref)
        assert (exact_depth > 0.01).mean() < 0.003
        assert (linear_depth > 0.01).mean() > 0.05  # the fences it stepped through
    finally:
        r.release()


def test_a_context_made_and_released_elsewhere_does_not_change_the_frame(gl_ctx):
    """Another context created and released in the process (a command run in-process, the
    user's own) leaves none of ours current; the renderer must still draw with its own
    context — with the program compiled before, not another context's object of that name."""
    from terrascape.relief.fields import fence_field
    from terrascape.render.context import create_headless_context, current
    from terrascape.render.relief_quad import ReliefQuadRenderer, ReliefSettings

    fences = fence_field(N, seed=3, fences=10)
    cam = _camera(75, azimuth=25)
    fixed = ReliefSettings(march="fixed", linear_steps=16, binary_steps=8)
    with current(gl_ctx):  # gives the test's own context back at the end
        first = ReliefQuadRenderer(gl_ctx, fences, size=(FB, FB))
        before = first.render(TILED, cam, "relief", settings=fixed).copy()  # compiles
        first.release()
        other = create_headless_context()
        other.release()
        second = ReliefQuadRenderer(gl_ctx, fences, size=(FB, FB))
        try:
            after = second.render(TILED, cam, "relief", settings=fixed)
        finally:
            second.release()
    assert np.abs(before[..., 2]).max() > 0.5  # hits at depth, not an empty frame
    np.testing.assert_array_equal(after, before)


def test_auto_draws_the_exact_tracer_on_square_textures(gl_ctx, city):
    from terrascape.render.relief_quad import ReliefQuadRenderer, choose_technique

    assert choose_technique(city) == "minmax"
    assert choose_technique(np.zeros((64, 96), np.float32)) == "relief"
    r = ReliefQuadRenderer(gl_ctx, city, size=(FB, FB))
    try:
        cam = _camera(70, azimuth=20)
        auto = r.render(TILED, cam)  # technique="auto" is the default
        assert r.last_technique == "minmax"
        np.testing.assert_array_equal(auto, r.render(TILED, cam, "minmax"))
    finally:
        r.release()
