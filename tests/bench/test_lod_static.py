"""``terrascape bench lod``'s static meshers table: one row per mesher of the table, map and
error, with the error measured on every sample and the ratios to the default mesher."""

from __future__ import annotations

import pytest

from terrascape.bench.lod import STATIC_ERRORS, static_mesher_table
from terrascape.lod.static_meshers import DEFAULT_STATIC_MESHER, STATIC_MESHERS


@pytest.fixture(scope="module")
def table():
    return static_mesher_table(quick=True)


def test_every_mesher_map_and_error_has_its_row(table):
    keys = [(row[0], row[1], row[2]) for row in table.rows]
    maps = list(dict.fromkeys(k[0] for k in keys))
    assert len(maps) == 2 and "Jacksboro DEM 344×403" in maps
    assert keys == [(m, e, name) for m in maps for e in STATIC_ERRORS for name in STATIC_MESHERS]


def test_errors_are_measured_and_within_the_bound(table):
    from terrascape.bench.peers import real_dem
    from terrascape.lod import max_vertical_error

    for _, error, _, triangles, _, build, _, measured in table.rows:
        assert 0 < measured <= error * (1 + 1e-6) and triangles > 0 and build > 0
    assert [t.met for t in table.targets] == [True]
    # the DEM's rows are the meshers' own meshes, measured again here
    dem = real_dem()
    for _, error, name, triangles, _, _, _, measured in table.rows[
            -len(STATIC_ERRORS) * len(STATIC_MESHERS):]:
        tri = STATIC_MESHERS[name].mesh(dem, max_error=error)
        assert len(tri) == triangles
        assert max_vertical_error(dem, tri) == pytest.approx(measured)


def test_ratios_are_to_the_default_mesher(table):
    default = {(row[0], row[1]): row for row in table.rows if row[2] == DEFAULT_STATIC_MESHER}
    for row in table.rows:
        base = default[row[0], row[1]]
        assert row[4] == pytest.approx(row[3] / base[3])
        assert row[6] == pytest.approx(row[5] / base[5])
    # the greedy TIN's reason to exist: fewer triangles at every error
    for row in table.rows:
        if row[2] == "greedy":
            assert row[4] < 1.0
