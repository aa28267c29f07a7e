"""The peer rows of ``bench peers`` compare like with like: the same shading as
xarray-spatial, the same triangles as pyvista, a skipped row (not a failure) without a peer."""

from __future__ import annotations

import importlib.util

import pytest

from terrascape.bench import BenchTable, peers


def _table() -> BenchTable:
    return BenchTable("t", ["a", "b", "c", "d", "e", "f", "g", "h"])


@pytest.mark.skipif(importlib.util.find_spec("xrspatial") is None, reason="xarray-spatial")
def test_hillshade_peer_computes_the_same_shading() -> None:
    table = _table()
    peers._hillshade_rows(65, 1, table)
    (row,) = table.rows
    assert row[-1] > 0.999  # correlation with xarray-spatial on the inner samples


@pytest.mark.skipif(importlib.util.find_spec("pyvista") is None, reason="pyvista")
def test_mesh_peer_builds_the_same_triangles() -> None:
    table = _table()
    peers._mesh_rows(33, 1, table)
    (row,) = table.rows
    assert row[-2] == row[-1] == 2 * 32 * 32


def test_a_missing_peer_is_a_skipped_row(monkeypatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(peers.importlib.util, "find_spec",
                        lambda name, *a: None if name in ("xrspatial", "pyvista") else real(name))
    hill, mesh = _table(), _table()
    peers._hillshade_rows(33, 1, hill)
    peers._mesh_rows(33, 1, mesh)
    assert hill.rows[0][2] == "-" and "not installed" in hill.notes[0]
    assert mesh.rows[0][2] == "-" and "not installed" in mesh.notes[0]


def test_a_missing_noise_peer_says_how_to_install_it(monkeypatch) -> None:
    """pyfastnoisesimd is in no extra (its source package builds only without build
    isolation): its skipped row says how to install it."""
    import sys

    from terrascape.bench import generate

    monkeypatch.setitem(sys.modules, "pyfastnoisesimd", None)  # import raises ImportError
    fill, about = generate._fastnoise(1)
    assert fill is None
    assert "not installed" in about and "pip install --no-build-isolation pyfastnoisesimd" in about
