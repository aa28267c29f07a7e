"""Scattering by rules: Poisson spacing across rules, density on a flat map, slope/height/mask
and sea-level rules, determinism, the caps, feet on the surface, the default rules' ecology."""

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from terrascape import Heightmap
from terrascape.errors import FileFormatError, InvalidParameterError
from terrascape.generate import generate
from terrascape.objects import Band, RuleSet, ScatterRule, scatter, surface_height
from terrascape.objects.rules import fit_limit_per_hectare, ruleset_from_dict


@pytest.fixture(scope="module")
def hilly():
    return generate("diamond-square", 129, seed=3, spacing=4.0)


def _spacing_of(inst, rules):
    by_rule = np.concatenate([np.full(r["placed"], rule.spacing)
                              for r, rule in zip(inst.metadata["rules"], rules, strict=True)])
    return by_rule


def _check_spacing(inst, spacing):
    xz = inst.positions[:, [0, 2]].astype(np.float64)
    pairs = cKDTree(xz).query_pairs(float(spacing.max()), output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(xz[pairs[:, 0]] - xz[pairs[:, 1]], axis=1)
        need = np.maximum(spacing[pairs[:, 0]], spacing[pairs[:, 1]])
        assert np.all(d >= need), float((d - need).min())
    return len(pairs)


def test_poisson_spacing_holds_for_every_pair_across_rules(hilly):
    rules = (ScatterRule("big", ("house",), density=2.0, spacing=30.0),
             ScatterRule("mid", ("conifer",), density=100.0, spacing=6.0),
             ScatterRule("small", ("bush",), density=400.0, spacing=2.0))
    inst = scatter(hilly, rules, seed=5)
    placed = [r["placed"] for r in inst.metadata["rules"]]
    assert all(p > 0 for p in placed) and len(inst) == sum(placed)
    spacing = _spacing_of(inst, rules)
    assert _check_spacing(inst, spacing) > 100  # neighbours near the limit were really tested
    # the kinds follow the rules, in order
    names = [inst.meshes[k].name for k in inst.kind]
    assert names[:placed[0]] == ["house"] * placed[0]


def test_density_on_a_flat_map():
    flat = Heightmap(np.zeros((257, 257), np.float32), 2.0)  # 512 × 512 m = 26.2144 ha
    rule = ScatterRule("trees", ("conifer",), density=50.0, spacing=4.0)
    inst = scatter(flat, rule, seed=2)
    ha = 512.0 * 512.0 / 1e4
    assert inst.metadata["rules"][0]["asked"] == round(50.0 * ha)
    assert abs(len(inst) - 50.0 * ha) <= 1
    # uniform: each quarter holds its share (binomial 1σ ≈ 3 %)
    x, z = inst.positions[:, 0], inst.positions[:, 2]
    for qx in (x < 256, x >= 256):
        for qz in (z < 256, z >= 256):
            assert abs(np.count_nonzero(qx & qz) / len(inst) - 0.25) < 0.04
    assert np.all((x >= 0) & (x <= 512) & (z >= 0) & (z <= 512))
    _check_spacing(inst, np.full(len(inst), 4.0))
    # scale and yaw ranges
    assert inst.scale.min() >= 0.8 and inst.scale.max() <= 1.2 and np.ptp(inst.scale) > 0.3
    assert inst.yaw.min() >= 0 and inst.yaw.max() < 2 * math.pi and np.ptp(inst.yaw) > 6


def _corner_values(field, hm, inst):
    dx, dz = hm.spacing
    c = np.minimum((inst.positions[:, 0] / dx).astype(int), hm.cols - 2)
    r = np.minimum((inst.positions[:, 2] / dz).astype(int), hm.rows - 2)
    return np.stack([field[r, c], field[r + 1, c], field[r, c + 1], field[r + 1, c + 1]], 1)


def test_slope_and_height_rules_are_respected(hilly):
    slope = np.degrees(hilly.slope())
    steep = ScatterRule("steep", ("rock",), density=60.0, spacing=3.0, slope=Band(30.0, 90.0))
    gentle = ScatterRule("gentle low", ("bush",), density=60.0, spacing=3.0,
                         slope=Band(0.0, 12.0, 4.0), height=Band(-math.inf, 60.0))
    high = ScatterRule("high", ("conifer",), density=60.0, spacing=3.0,
                       height_fraction=Band(0.7, 1.0))
    for rule, ok in ((steep, lambda s, h: s >= 30.0),
                     (gentle, lambda s, h: (s < 16.0) & (h <= 60.0)),
                     (high, lambda s, h: h >= hilly.min + 0.7 * (hilly.max - hilly.min))):
        inst = scatter(hilly, rule, seed=1)
        assert len(inst) > 20, rule.name
        s = _corner_values(slope, hilly, inst)
        h = _corner_values(hilly.heights, hilly, inst)
        # the object's cell has a suitable corner (suitability is averaged onto cells)
        assert np.all(ok(s, h).any(axis=1)), rule.name
    # and the unsuitable ground stays empty when the whole map is unsuitable
    none = scatter(hilly, ScatterRule("x", ("rock",), density=60.0, spacing=3.0,
                                      slope=Band(89.0, 90.0)), seed=1)
    assert len(none) == 0 and none.metadata["rules"][0]["placed"] == 0


def test_soft_ramp_thins_gradually():
    b = Band(10.0, 20.0, 5.0)
    np.testing.assert_allclose(b.weight([4, 5, 7.5, 10, 15, 20, 22.5, 25, 30]),
                               [0, 0, 0.5, 1, 1, 1, 0.5, 0, 0])


def test_sea_level_and_feet_on_the_surface(hilly):
    sea = hilly.min + 0.4 * (hilly.max - hilly.min)
    for exaggeration in (1.0, 2.5):
        inst = scatter(hilly, seed=4, sea_level=sea, exaggeration=exaggeration)
        assert len(inst) > 100
        y = surface_height(hilly, inst.positions[:, 0], inst.positions[:, 2], exaggeration)
        assert np.abs(inst.positions[:, 1] - y).max() < 1e-4
        assert (inst.positions[:, 1] / np.float32(exaggeration)).min() >= sea - 1e-3


def test_same_seed_same_bytes_other_seed_other_places(hilly):
    a = scatter(hilly, seed=9)
    b = scatter(hilly, seed=9)
    c = scatter(hilly, seed=10)
    for name in ("kind", "positions", "scale", "yaw"):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()
    assert a.positions.tobytes() != c.positions.tobytes()


def test_caps_are_clear_errors():
    flat = Heightmap(np.zeros((257, 257), np.float32), 2.0)
    limit = fit_limit_per_hectare(4.0)
    with pytest.raises(InvalidParameterError, match=r"asks for 900 objects per hectare with a "
                       r"spacing of 4, but at most 250 per hectare fit"):
        scatter(flat, ScatterRule("dense", ("bush",), density=900.0, spacing=4.0))
    assert limit == pytest.approx(250.0)
    with pytest.raises(InvalidParameterError, match=r"ask for 5,243 objects.*cap of 1,000"):
        scatter(flat, ScatterRule("many", ("bush",), density=200.0, spacing=4.0),
                max_objects=1000)
    # the built-in rules lower their densities to the cap instead
    inst = scatter(Heightmap(np.zeros((257, 257), np.float32), 8.0), max_objects=500)
    assert len(inst) <= 500 and inst.metadata["density_factor"] < 1


def test_masks_and_materials(hilly):
    wear = np.zeros(hilly.shape, np.float32)
    wear[:, :40] = 1.0
    rule = ScatterRule("worn", ("rock",), density=40.0, spacing=3.0,
                       masks={"wear": Band(0.5, 1.0)})
    inst = scatter(hilly, rule, masks={"wear": wear}, seed=3)
    assert len(inst) > 50 and inst.positions[:, 0].max() <= 40 * 4.0
    with pytest.raises(InvalidParameterError, match="reads the wear mask, which was not given"):
        scatter(hilly, rule)
    rocky = ScatterRule("on rock", ("rock",), density=40.0, spacing=3.0,
                        materials={"rock": Band(0.5, 1.0)})
    from terrascape.texture import material_weights

    w = material_weights(hilly, seed=3)[2]  # the scatter reads them with its seed
    inst = scatter(hilly, rocky, seed=3)
    assert np.all((_corner_values(w, hilly, inst) >= 0.5).any(axis=1))


def test_default_rules_put_each_kind_where_it_belongs(hilly):
    inst = scatter(hilly, seed=1)
    names = [m.name for m in inst.meshes]
    frac = (inst.positions[:, 1] - hilly.min) / (hilly.max - hilly.min)
    slope = np.degrees(hilly.slope())
    s = _corner_values(slope, hilly, inst).mean(axis=1)
    def of(name):
        return inst.kind == names.index(name)
    assert of("conifer").sum() > 50 and of("broadleaf").sum() > 50
    assert frac[of("conifer")].mean() > frac[of("broadleaf")].mean() + 0.15
    assert s[of("rock")].mean() > s[of("broadleaf")].mean() + 5
    counts = {r["name"]: r["placed"] for r in inst.metadata["rules"]}
    assert counts["houses"] < counts["conifers"] / 20


def test_rules_file_keys_are_checked():
    good = {"sea_level": 3.0, "rules": [{"name": "a", "meshes": ["bush"], "density": 5,
                                         "spacing": 2, "slope": {"max": 30, "ramp": 5},
                                         "height_fraction": [0.1, 0.9]}]}
    rs = ruleset_from_dict(good)
    assert isinstance(rs, RuleSet) and rs.sea_level == 3.0
    assert rs.rules[0].slope == Band(-math.inf, 30.0, 5.0)
    for bad, message in (
        ({"rules": [{**good["rules"][0], "dencity": 3}]}, "unknown key 'dencity'"),
        ({**good, "sealevel": 1}, "unknown key 'sealevel'"),
        ({"rules": [{**good["rules"][0], "slope": {"maxi": 3}}]}, "unknown key 'maxi'"),
        ({"rules": [{**good["rules"][0], "masks": {"mud": [0, 1]}}]}, "unknown mask 'mud'"),
        ({"rules": [{"name": "a", "meshes": ["bush"], "density": 5}]}, "missing key 'spacing'"),
        ({"rules": [{**good["rules"][0], "density": -1}]}, "density must be ≥ 0"),
        ({"rules": []}, "at least one"),
    ):
        with pytest.raises(InvalidParameterError, match=message):
            ruleset_from_dict(bad)
    with pytest.raises(InvalidParameterError, match="unknown mesh 'palm'"):
        scatter(Heightmap(np.zeros((9, 9), np.float32)),
                ScatterRule("p", ("palm",), density=1, spacing=1))


def test_load_objects_resolves_every_spec(hilly, tmp_path):
    import trimesh

    from terrascape.objects import load_objects

    a = load_objects("default", hilly, seed=2)
    b = scatter(hilly, seed=2)
    assert a.positions.tobytes() == b.positions.tobytes()
    # the user's model, scattered by the default tree rule
    cone = trimesh.creation.cone(radius=2.0, height=9.0)
    cone.apply_transform(trimesh.transformations.rotation_matrix(-np.pi / 2, [1, 0, 0]))
    (tmp_path / "pine.glb").write_bytes(trimesh.Scene(cone).export(file_type="glb"))
    mine = load_objects(str(tmp_path / "pine.glb"), hilly, seed=2)
    assert [m.name for m in mine.meshes] == ["pine"] and len(mine) > 50
    assert mine.metadata["rules"][0]["name"] == "trees"
    # a rules file naming the model and a built-in mesh, with a sea level
    (tmp_path / "r.toml").write_text(
        'sea_level = 40.0\n[meshes]\npine = "pine.glb"\n'
        '[[rules]]\nname = "pines"\nmeshes = ["pine", "conifer"]\ndensity = 30\nspacing = 6\n'
        'slope = {max = 35, ramp = 5}\nscale = [0.9, 1.1]\n')
    ruled = load_objects(str(tmp_path / "r.toml"), hilly, seed=2)
    assert {m.name for m in ruled.meshes} == {"pine", "conifer"}
    assert ruled.positions[:, 1].min() >= 40.0 - 1e-3 and ruled.scale.max() <= 1.1 + 1e-6
    (tmp_path / "r.json").write_text(json.dumps({"rules": [{"name": "r", "meshes": ["rock"],
                                                            "density": 10, "spacing": 3}]}))
    assert len(load_objects(str(tmp_path / "r.json"), hilly, seed=2)) > 10
    (tmp_path / "bad.toml").write_text('[[rules]]\nname = "x"\nmeshes = ["rock"]\n'
                                       'density = 5\nspacing = 2\nheigth = [0, 1]\n')
    with pytest.raises(InvalidParameterError, match=r"bad\.toml: rule 'x': unknown key 'heigth'"):
        load_objects(str(tmp_path / "bad.toml"), hilly)
    (tmp_path / "broken.toml").write_text("[[rules]\n")
    with pytest.raises(FileFormatError, match="not valid TOML"):
        load_objects(str(tmp_path / "broken.toml"), hilly)
    with pytest.raises(InvalidParameterError, match="unknown --objects 'trees'"):
        load_objects("trees", hilly)
