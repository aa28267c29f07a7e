"""``mesh`` and ``render`` warn when a map's spacing looks like degrees and no CRS says so
(the real Jacksboro DEM, 403 × 344 samples 0.00083° apart, heights 236–1076 m)."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.cli import run_app
from terrascape.io.tiff import read_tiff, write_tiff


def _jacksboro() -> tuple[np.ndarray, float]:
    from matplotlib.cbook import get_sample_data

    d = get_sample_data("jacksboro_fault_dem.npz")
    return d["elevation"].astype(np.float32), float(d["dx"])


def test_mesh_warns_about_degrees_and_not_about_metres(tmp_path, capsys):
    z, deg = _jacksboro()
    np.save(tmp_path / "j.npy", z)
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(tmp_path / "d.obj"),
                    "--max-error", "20", "--spacing", str(deg), "-q"]) == 0
    err = capsys.readouterr().err
    assert "looks like degrees" in err and "--spacing" in err
    assert run_app(["mesh", str(tmp_path / "j.npy"), "-o", str(tmp_path / "m.obj"),
                    "--max-error", "20", "--spacing", "74.5,92.6", "-q"]) == 0
    assert "looks like degrees" not in capsys.readouterr().err


@pytest.mark.gl
def test_render_warns_about_a_degree_tiff_without_crs(tmp_path, capsys):
    z, deg = _jacksboro()
    path = write_tiff(Heightmap(z, (deg, deg)), tmp_path / "j.tif")
    assert read_tiff(path).spacing == pytest.approx((deg, deg))  # kept, and no CRS
    out = tmp_path / "j.png"
    assert run_app(["render", str(path), "-o", str(out), "--size", "64x48", "-q"]) == 0
    err = capsys.readouterr().err
    assert "looks like degrees" in err and "terrascape convert j.tif" in err
    assert out.stat().st_size > 0
