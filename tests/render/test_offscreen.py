"""Off-screen rendering helpers: frames, turntables (PNG/MP4), atomic outputs."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from terrascape.errors import InvalidParameterError, OutputExistsError, TerrascapeError
from terrascape.heightmap import Heightmap
from terrascape.render.offscreen import (
    render_frames,
    render_to_array,
    turntable,
    turntable_cameras,
)

pytestmark = pytest.mark.gl


@pytest.fixture(scope="module")
def hm():
    x = np.linspace(-1, 1, 33)
    h = np.exp(-4 * (x[None, :] ** 2 + x[:, None] ** 2)) * 6
    return Heightmap(h.astype(np.float32), (0.5, 0.5))


def test_default_camera_frames_whole_terrain(gl_ctx, hm):
    # The overview (an elevation given) still fits the whole terrain; the default camera is
    # now the landscape view (terrain filling the image below the horizon, checked below).
    from terrascape.render.offscreen import default_camera

    cam = default_camera(hm, (64, 48), elevation=35.0)
    img = render_to_array(hm, size=(64, 48), ctx=gl_ctx, camera=cam, params={"sky": False})
    bg = img[0, 0]
    fg = np.any(img != bg, axis=-1)
    rows, cols = np.nonzero(fg)
    # terrain is visible, centred, and does not touch the image border (whole terrain in view)
    assert fg.mean() > 0.05
    assert rows.min() > 0 and cols.min() > 0 and rows.max() < 47 and cols.max() < 63
    assert abs(cols.mean() - 32) < 8


def test_default_camera_is_a_landscape_view(gl_ctx, hm):
    img = render_to_array(hm, size=(64, 48), ctx=gl_ctx, params={"sky": False})
    fg = np.any(img != img[0, 0], axis=-1)
    assert not fg[:6].any()  # sky band at the top (the horizon a quarter down)
    assert fg[-4:].all()  # the terrain reaches the bottom edge across the whole width


def test_render_frames_matches_single_renders(gl_ctx, hm):
    cams = turntable_cameras(hm, 3, size=(32, 24))
    assert len({c.yaw for c in cams}) == 3
    frames = list(render_frames(hm, cams, size=(32, 24), ctx=gl_ctx))
    assert len(frames) == 3 and not np.array_equal(frames[0], frames[1])
    single = render_to_array(hm, camera=cams[1], size=(32, 24), ctx=gl_ctx)
    np.testing.assert_array_equal(frames[1], single)


def test_turntable_png_sequence(gl_ctx, hm, tmp_path):
    files = turntable(hm, 2, tmp_path / "spin.png", size=(32, 24), ctx=gl_ctx)
    assert [f.name for f in files] == ["spin_0000.png", "spin_0001.png"]
    cams = turntable_cameras(hm, 2, size=(32, 24))
    expected = list(render_frames(hm, cams, size=(32, 24), ctx=gl_ctx))
    for f, e in zip(files, expected, strict=True):
        np.testing.assert_array_equal(np.asarray(Image.open(f)), e[..., :3])
    # existing frame and no --force: refused before anything is written
    (tmp_path / "other_0001.png").write_bytes(b"keep")
    with pytest.raises(OutputExistsError):
        turntable(hm, 2, tmp_path / "other.png", size=(32, 24), ctx=gl_ctx)
    assert not (tmp_path / "other_0000.png").exists()
    assert (tmp_path / "other_0001.png").read_bytes() == b"keep"


def test_turntable_png_sequence_is_one_unit(gl_ctx, hm, tmp_path, monkeypatch):
    """A failure on the last frame leaves no frame of the sequence behind."""
    import terrascape.render.offscreen as offscreen

    written = []
    real = offscreen._write_png

    def failing(path, image):
        if len(written) == 2:
            raise OSError(28, "No space left on device", str(path))
        written.append(path)
        real(path, image)

    monkeypatch.setattr(offscreen, "_write_png", failing)
    with pytest.raises(TerrascapeError, match="space"):
        turntable(hm, 3, tmp_path / "spin.png", size=(32, 24), ctx=gl_ctx)
    assert len(written) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_turntable_mp4(gl_ctx, hm, tmp_path):
    import imageio.v2 as imageio

    out = tmp_path / "spin.mp4"
    turntable(hm, 3, out, fmt="mp4", size=(32, 24), ctx=gl_ctx)
    reader = imageio.get_reader(out)
    frames = [f for f in reader]
    reader.close()
    assert len(frames) == 3 and frames[0].shape == (24, 32, 3)
    assert [p.name for p in tmp_path.iterdir()] == ["spin.mp4"]  # no temp leftovers
    with pytest.raises(InvalidParameterError, match="even"):
        turntable(hm, 2, tmp_path / "odd.mp4", fmt="mp4", size=(33, 24), ctx=gl_ctx)
    with pytest.raises(InvalidParameterError, match="format"):
        turntable(hm, 2, tmp_path / "x.gif", fmt="gif", ctx=gl_ctx)
    assert not (tmp_path / "odd.mp4").exists()
