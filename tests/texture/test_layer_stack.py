"""3D-texture layer stack and the height → r coordinate (Filipović 2008 §3.1.2)."""

import numpy as np
import pytest

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.texture.layer_stack import layer_coordinate, layer_stack
from terrascape.texture.regions import Region, default_regions, region_weights


def test_layer_coordinate_values():
    regs = [Region("a", 10.0, 10.0), Region("b", 20.0, 10.0), Region("c", 40.0, 20.0),
            Region("d", 50.0, 10.0)]
    h = np.array([[0.0, 10.0, 15.0, 20.0], [30.0, 40.0, 45.0, 99.0]], np.float32)
    r = layer_coordinate(Heightmap(h), regs)
    assert r.dtype == np.float32 and r.shape == (2, 4)
    np.testing.assert_allclose(r[0], [0.5 / 4, 0.5 / 4, 1.0 / 4, 1.5 / 4], atol=1e-7)
    np.testing.assert_allclose(r[1], [2.0 / 4, 2.5 / 4, 3.0 / 4, 3.5 / 4], atol=1e-7)
    assert layer_coordinate(Heightmap(h), [Region("only", 5.0, 1.0)]).max() == 0.5


def test_layer_coordinate_blend_equals_region_weights(rng):
    # Sampling a 3D texture at r with linear filtering blends layers floor(rL-0.5) and the
    # next; with the default (complementary hat) bands this equals the thesis's weights.
    h = rng.uniform(-5, 105, size=(16, 16)).astype(np.float32)
    h[0, 0], h[0, 1] = 0.0, 100.0
    hm = Heightmap(h)
    regs = default_regions(hm)
    n = len(regs)
    s = layer_coordinate(hm) * n - 0.5
    i0 = np.clip(np.floor(s).astype(int), 0, n - 2)
    t = np.clip(s - i0, 0.0, 1.0)
    implied = np.zeros((n, *h.shape))
    rows, cols = np.indices(h.shape)
    implied[i0, rows, cols] += 1 - t
    implied[i0 + 1, rows, cols] += t
    np.testing.assert_allclose(implied, region_weights(h, regs), atol=1e-5)


def test_layer_coordinate_needs_ordered_regions():
    hm = Heightmap(np.zeros((3, 3), np.float32))
    with pytest.raises(InvalidParameterError, match="increasing"):
        layer_coordinate(hm, [Region("b", 20.0, 5.0), Region("a", 10.0, 5.0)])
    with pytest.raises(InvalidParameterError, match="empty"):
        layer_coordinate(hm, [])


def test_layer_stack_shapes_order_and_resizing(tmp_path):
    from PIL import Image

    red = np.zeros((8, 8, 3), np.uint8)
    red[..., 0] = 255
    grey = np.full((16, 16), 0.5, np.float32)
    Image.fromarray(np.full((4, 4, 3), 7, np.uint8)).save(tmp_path / "seven.png")
    stack = layer_stack([red, grey, tmp_path / "seven.png", "snow"])
    assert stack.shape == (4, 8, 8, 3) and stack.dtype == np.uint8
    assert stack.flags.c_contiguous
    assert stack[0, ..., 0].min() == 255 and stack[0, ..., 1].max() == 0
    assert np.all(stack[1] == 128)  # 0.5 -> 128, 2×2 box-reduced
    assert np.all(stack[2] == 7)
    assert stack[3].mean() > 200  # built-in snow
    assert layer_stack([red], size=(4, 6)).shape == (1, 4, 6, 3)
    assert layer_stack([red, red], size=32).shape == (2, 32, 32, 3)


def test_layer_stack_bad_input(tmp_path):
    with pytest.raises(InvalidParameterError, match="at least one layer"):
        layer_stack([])
    with pytest.raises(InvalidParameterError, match="channels"):
        layer_stack([np.zeros((4, 4, 2), np.uint8)])
    with pytest.raises(InvalidParameterError, match="list"):
        layer_stack(np.zeros((2, 4, 4, 3), np.uint8))
    (tmp_path / "x.png").write_bytes(b"garbage")
    with pytest.raises(FileFormatError):
        layer_stack([tmp_path / "x.png"])
    with pytest.raises(InvalidParameterError, match="size"):
        layer_stack([np.zeros((4, 4, 3), np.uint8)], size=(4, 4, 4))
