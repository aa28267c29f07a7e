"""A night render's horizon: the sky meets the world beyond the terrain (haze or the
textured plane) without a line, along every column."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from terrascape.cli.app import run_app
from terrascape.heightmap import Heightmap
from terrascape.io import write_heightmap

pytestmark = pytest.mark.gl

LUMA = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def npy_map(tmp_path_factory):
    y, x = np.mgrid[0:33, 0:33] / 32.0
    h = (8.0 * np.sin(3 * x) * np.cos(2 * y) + 8.0).astype(np.float32)
    path = tmp_path_factory.mktemp("night") / "hm.npy"
    write_heightmap(Heightmap(h, (2.0, 2.0)), path)
    return path


def _horizon_profile(npy_map, out, time, surround):
    # from the terrain's edge, looking away from it and 1.8° down: sky above, the world
    # beyond the edge below, the horizon a little above the middle row
    assert run_app(["render", str(npy_map), "-o", str(out), "--size", "96x64", "-q",
                    "--technique", "plain", "--time", time, "--latitude", "45.8",
                    "--camera", "32,20,-40", "--target", "32,12,-300",
                    "--surround", surround]) == 0
    lum = np.asarray(Image.open(out))[..., :3].astype(float) @ LUMA
    # the median over the columns: a line across the frame shows, single stars do not
    return np.median(lum, axis=1)


@pytest.mark.parametrize("surround", ["fade", "plane"])
def test_night_horizon_has_no_line(npy_map, tmp_path, surround):
    profile = _horizon_profile(npy_map, tmp_path / "night.png", "2026-06-21T23:30", surround)
    jumps = np.abs(np.diff(profile))
    assert jumps.max() < 4.0, (jumps.argmax(), profile.round())
    # a night frame, not a black or a blank one
    assert 5.0 < profile.mean() < 120.0
