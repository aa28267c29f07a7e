import numpy as np
import pytest

from terrascape import Heightmap
from terrascape._validate import check_pow2_plus1_square, is_pow2_plus1, make_rng
from terrascape.errors import HeightmapSizeError, InvalidParameterError


def test_heights_become_readonly_float32():
    hm = Heightmap(np.arange(12, dtype=np.int16).reshape(3, 4), spacing=2.0)
    assert hm.heights.dtype == np.float32
    assert hm.heights.flags.c_contiguous
    assert not hm.heights.flags.writeable
    assert hm.spacing == (2.0, 2.0)
    assert hm.shape == (3, 4) and hm.rows == 3 and hm.cols == 4
    assert hm.extent == (6.0, 4.0)
    assert (hm.min, hm.max) == (0.0, 11.0)


@pytest.mark.parametrize(
    ("heights", "spacing"),
    [
        (np.zeros(5), 1.0),
        (np.zeros((1, 5)), 1.0),
        (np.array([[0, np.nan], [0, 0]]), 1.0),
        (np.zeros((3, 3)), 0.0),
        (np.zeros((3, 3)), (1.0, -2.0)),
        (np.zeros((3, 3)), (1.0, 2.0, 3.0)),
    ],
)
def test_bad_heightmaps_raise(heights, spacing):
    with pytest.raises(InvalidParameterError):
        Heightmap(heights, spacing)


def test_pow2_plus1_checks():
    assert [n for n in range(20) if is_pow2_plus1(n)] == [3, 5, 9, 17]
    assert check_pow2_plus1_square((17, 17), algorithm="x") == 17
    with pytest.raises(HeightmapSizeError, match="got 16×17"):
        check_pow2_plus1_square((17, 16), algorithm="ROAM")


def test_pad_keeps_samples_and_spacing():
    h = np.random.default_rng(0).random((10, 7)).astype(np.float32)
    hm = Heightmap(h, (2.0, 3.0)).to_pow2_plus1("pad")
    assert hm.shape == (17, 17)
    assert np.array_equal(hm.heights[:10, :7], h)
    assert np.array_equal(hm.heights[10:, :7], np.broadcast_to(h[-1], (7, 7)))
    assert hm.spacing == (2.0, 3.0)


def test_resample_keeps_extent_and_linear_ramp():
    x = np.linspace(0, 1, 20, dtype=np.float32)
    ramp = np.broadcast_to(x, (20, 20))
    hm = Heightmap(ramp, 1.0).to_pow2_plus1("resample")
    assert hm.shape == (17, 17)
    assert hm.extent == pytest.approx((19.0, 19.0))
    # cubic-spline boundary handling costs < 0.2 % of the range at the edges
    assert np.allclose(hm.heights[0], np.linspace(0, 1, 17), atol=2e-3)


def test_normalise_and_scale():
    hm = Heightmap(np.array([[2, 4], [6, 10]]))
    assert np.allclose(hm.normalised(-1, 1).heights, [[-1, -0.5], [0, 1]])
    assert np.allclose(hm.scaled(0.5).heights, [[1, 2], [3, 5]])
    assert np.all(Heightmap(np.ones((3, 3))).normalised().heights == 0)


def test_normals_and_slope_of_a_tilted_plane():
    # h = 0.5 x - 0.25 z with dx = 2, dz = 4
    rows, cols = 9, 11
    x = np.arange(cols) * 2.0
    z = np.arange(rows) * 4.0
    h = 0.5 * x[None, :] - 0.25 * z[:, None]
    hm = Heightmap(h, (2.0, 4.0))
    hx, hz = hm.gradient()
    assert np.allclose(hx, 0.5) and np.allclose(hz, -0.25)
    n = hm.normals()
    expected = np.array([-0.5, 1.0, 0.25]) / np.linalg.norm([-0.5, 1.0, 0.25])
    assert np.allclose(n, expected, atol=1e-6)
    assert np.allclose(hm.slope(), np.arctan(np.hypot(0.5, 0.25)))


def test_make_rng_is_deterministic_and_validates():
    assert make_rng(3).random() == make_rng(3).random()
    assert make_rng(None).random() == make_rng(0).random()
    with pytest.raises(InvalidParameterError):
        make_rng(-1)


def test_slope_in_row_blocks_equals_the_whole_map_formula():
    """Heightmap.slope runs over blocks of rows with a halo: the same bits as the formula on
    the whole map's gradient, at the borders and at every block edge."""
    from terrascape.generate.registry import generate

    for shape in [(2, 5), (3, 3), (70, 45), (300, 17)]:
        hm = generate("fbm", shape, seed=3, spacing=(1.5, 2.0))
        hx, hz = hm.gradient()
        assert np.array_equal(hm.slope(), np.arctan(np.hypot(hx, hz)).astype(np.float32))
