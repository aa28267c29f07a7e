import numpy as np
import pytest

from terrascape.errors import HeightmapSizeError
from terrascape.relief.cone_map import cone_map, cone_map_bruteforce, footprint_cone_map
from terrascape.relief.fields import city_field, natural_field
from terrascape.relief.minmax_mip import minmax_mip
from terrascape.relief.prewarp import sample_bilinear


@pytest.mark.parametrize("field", ["city", "natural"])
def test_cone_map_equals_bruteforce_definition(field):
    h = city_field(16, block=8, street=2, seed=1) if field == "city" else natural_field(16)
    np.testing.assert_allclose(cone_map(h), cone_map_bruteforce(h), rtol=1e-6)


def test_cone_of_single_pit():
    h = np.ones((8, 8))
    h[4, 4] = 0.0  # one texel of depth 1; everything else at depth 0
    c = cone_map(h, c_max=5.0)
    assert c[4, 4] == pytest.approx(1.0 / 8)  # nearest higher texel one texel away
    assert np.all(np.delete(c.ravel(), 4 * 8 + 4) == 5.0)


def test_footprint_cones_are_empty_of_the_bilinear_surface():
    # From any point of texel i's footprint above the apex, the cone must not contain
    # any point of the bilinear surface: sample both densely and check.
    h = natural_field(16, seed=3)
    fc = footprint_cone_map(h)
    rng = np.random.default_rng(0)
    q = rng.uniform(0, 1, (4000, 2))
    dq = 1.0 - sample_bilinear(h, q, wrap=True)
    for _ in range(40):
        i, j = rng.integers(0, 16, 2)
        apex, ratio = fc[i, j]
        p = (np.array([j, i]) + 0.5 + rng.uniform(-0.5, 0.5, 2)) / 16
        d = np.abs(q - p)
        dist = np.hypot(*np.minimum(d, 1 - d).T)
        inside = dist < ratio * (apex - dq) - 1e-9
        assert not inside.any()
    assert (fc[..., 1] > 0).all()


def test_minmax_mip_bounds_every_cell():
    h = city_field(32, block=16, seed=2)
    levels = minmax_mip(h)
    assert [lv.shape[0] for lv in levels] == [32, 16, 8, 4, 2, 1]
    d = 1.0 - h
    rng = np.random.default_rng(1)
    q = rng.uniform(0, 1, (3000, 2))
    dq = 1.0 - sample_bilinear(h, q, wrap=True)
    cell = np.floor(q * 32 - 0.5).astype(int) % 32
    for k, lv in enumerate(levels):
        node = cell >> k
        lo = lv[node[:, 1], node[:, 0], 0]
        hi = lv[node[:, 1], node[:, 0], 1]
        assert (dq >= lo - 1e-6).all() and (dq <= hi + 1e-6).all()
    assert levels[-1][0, 0, 0] == d.min() and levels[-1][0, 0, 1] == d.max()
    with pytest.raises(HeightmapSizeError):
        minmax_mip(np.zeros((24, 24)))
