"""Built-in materials: seamless tiling, determinism, and texture-spec validation."""

import numpy as np
import pytest

from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.texture.materials import (
    BUILTIN_MATERIALS,
    as_rgb_image,
    builtin_material,
    load_texture,
    read_image_rgb,
    resize_rgb,
)


@pytest.mark.parametrize("name", BUILTIN_MATERIALS)
def test_builtin_tiles_seamlessly(name):
    t = builtin_material(name, 128, seed=3).astype(np.float64)
    assert t.shape == (128, 128, 3)
    for axis in (0, 1):
        interior = np.abs(np.diff(t, axis=axis)).mean()
        first = np.take(t, 0, axis=axis)
        last = np.take(t, -1, axis=axis)
        wrap = np.abs(first - last).mean()
        # The seam is just another neighbour pair: same statistics as interior pairs.
        assert interior > 0.5  # the texture has structure, the test can fail
        assert wrap < 1.35 * interior, (name, axis, wrap, interior)


def test_non_periodic_texture_fails_the_seam_check():
    # Guard that the seam criterion is strict enough to catch a non-tiling texture.
    t = builtin_material("grass", 128, seed=1).astype(np.float64)
    crop = t[:, :90]  # a crop does not tile: its wrap joins columns 89 apart
    interior = np.abs(np.diff(crop, axis=1)).mean()
    wrap = np.abs(crop[:, 0] - crop[:, -1]).mean()
    assert wrap > 1.35 * interior


def test_builtins_are_deterministic_and_distinct():
    a = builtin_material("rock", 64, seed=7)
    b = builtin_material("rock", 64, seed=7)
    c = builtin_material("rock", 64, seed=8)
    assert a.tobytes() == b.tobytes()
    assert not np.array_equal(a, c)
    means = {n: builtin_material(n, 64).reshape(-1, 3).mean(axis=0) for n in BUILTIN_MATERIALS}
    assert means["water"][2] > means["water"][0] + 50  # blue
    assert means["grass"][1] > means["grass"][0] + 20  # green
    assert means["snow"].min() > 200  # bright
    assert builtin_material("SAND", 16).shape == (16, 16, 3)


def test_builtin_bad_input():
    with pytest.raises(InvalidParameterError, match="unknown built-in"):
        builtin_material("lava")
    with pytest.raises(InvalidParameterError, match="size"):
        builtin_material("rock", 2)
    with pytest.raises(InvalidParameterError, match="seed"):
        builtin_material("rock", 16, seed=-1)


def test_as_rgb_image_channels_and_dtypes():
    grey = np.linspace(0, 1, 12, dtype=np.float32).reshape(3, 4)
    out = as_rgb_image(grey)
    assert out.shape == (3, 4, 3) and out.dtype == np.uint8
    assert out[2, 3].tolist() == [255, 255, 255] and out[0, 0].tolist() == [0, 0, 0]
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[..., 0] = 9
    assert as_rgb_image(rgba)[..., 0].max() == 9 and as_rgb_image(rgba).shape == (2, 2, 3)
    assert as_rgb_image(np.full((2, 2), 65535, np.uint16)).max() == 255
    for bad_channels in (2, 5):
        with pytest.raises(InvalidParameterError, match="channels"):
            as_rgb_image(np.zeros((4, 4, bad_channels), np.uint8))
    with pytest.raises(InvalidParameterError, match=r"\[0, 1\]"):
        as_rgb_image(np.full((4, 4, 3), 2.0))
    with pytest.raises(InvalidParameterError, match="NaN"):
        as_rgb_image(np.full((4, 4, 3), np.nan))


def test_files_and_resizing(tmp_path):
    from PIL import Image

    img = np.zeros((8, 8, 3), np.uint8)
    img[:4] = (200, 10, 20)
    Image.fromarray(img).save(tmp_path / "t.png")
    assert np.array_equal(read_image_rgb(tmp_path / "t.png"), img)
    loaded = load_texture(str(tmp_path / "t.png"), default_name="x", size=4)
    assert loaded.shape == (4, 4, 3) and loaded[0, 0].tolist() == [200, 10, 20]
    assert loaded[3, 0].tolist() == [0, 0, 0]
    (tmp_path / "bad.png").write_text("not an image")
    with pytest.raises(FileFormatError, match="not a readable image"):
        read_image_rgb(tmp_path / "bad.png")
    with pytest.raises(FileFormatError, match="does not exist"):
        read_image_rgb(tmp_path / "missing.png")
    with pytest.raises(InvalidParameterError, match="not a built-in"):
        load_texture(None, default_name="lava", size=8)
    # power-of-two reductions are exact box means
    ramp = np.repeat(np.arange(0, 64, 8, dtype=np.uint8)[None, :, None], 8, axis=0)
    ramp = np.repeat(ramp, 3, axis=2)
    assert resize_rgb(ramp, (4, 4))[0, :, 0].tolist() == [4, 20, 36, 52]
