"""The frame-rate row against pyvista draws the same picture: both renderers show the
terrain from the same cameras (same share of the frame covered), timed frame by frame."""

from __future__ import annotations

import importlib.util

import pytest

from terrascape.bench import _render_peer

pytestmark = pytest.mark.gl


@pytest.mark.skipif(importlib.util.find_spec("pyvista") is None, reason="pyvista")
def test_both_renderers_frame_the_same_terrain() -> None:
    table = _render_peer.frame_rate_table(65, 1)
    (row,) = table.rows
    col = table.columns.index
    ours, peer = row[col("terrain in ours %")], row[col("terrain in peer %")]
    # the same camera and mesh: the terrain fills the same share of both frames
    assert ours > 5.0 and peer > 5.0
    assert abs(ours - peer) < 3.0
    assert row[col("ours/peer")] > 0 and row[col("ours ms/frame")] > 0
    assert row[col("ours frames/s")] == pytest.approx(1e3 / row[col("ours ms/frame")])


def test_without_pyvista_the_row_is_skipped(monkeypatch) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(_render_peer.importlib.util, "find_spec",
                        lambda name, *a: None if name == "pyvista" else real(name))
    table = _render_peer.frame_rate_table(65, 1)
    assert table.rows[0][2] == "-" and "not installed" in table.notes[0]
