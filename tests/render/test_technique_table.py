"""The technique table owns what is particular to a technique: its uniforms (a hook), the
parameters that are not uniforms, its fallback — and the one decision of what draws."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from terrascape.camera import Camera
from terrascape.errors import GLUnavailableError, InvalidParameterError
from terrascape.heightmap import Heightmap
from terrascape.render.techniques import (
    CPU_PARAMS,
    DrawnTechnique,
    Technique,
    TechniqueFallbackWarning,
    TextureSlot,
    build_region_texture,
    choose_drawable,
    get_technique,
    technique_names,
)


class _Context:
    """Stands in for a GL context: the decision is kept per context object."""


def test_fallback_is_decided_once_per_context_and_said_once():
    ctx, other = _Context(), _Context()
    tried = []

    def build(name):
        tried.append(name)
        if name == "fancy":
            raise GLUnavailableError("shader program 'fancy' failed to compile\nthe log")
        return f"program of {name}"

    with pytest.warns(TechniqueFallbackWarning, match="'fancy' is not available") as caught:
        built, drawn = choose_drawable(ctx, "fancy", build, fallback="plain")
    assert len(caught) == 1
    assert built == "program of plain"
    assert drawn == DrawnTechnique("fancy", "plain", "shader program 'fancy' failed to compile")
    assert drawn.fell_back
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # said once: the second frame is silent
        assert choose_drawable(ctx, "fancy", build, fallback="plain")[1] == drawn
    assert tried == ["fancy", "plain", "plain"]  # and not tried again on this context
    notes = []
    choose_drawable(other, "fancy", build, fallback="plain", warn=notes.append)
    assert len(notes) == 1 and "rendering plain texturing instead" in notes[0]
    built, drawn = choose_drawable(ctx, "plain", build, fallback="plain")
    assert built == "program of plain" and not drawn.fell_back
    with pytest.raises(GLUnavailableError, match="fancy"):
        choose_drawable(_Context(), "fancy", build, fallback=None)


def test_every_technique_names_a_registered_fallback():
    for name in technique_names():
        tech = get_technique(name)
        assert tech.fallback is None or get_technique(tech.fallback).fallback is None, name
    assert get_technique("plain").fallback is None  # the last resort raises


def test_parameters_read_on_the_cpu_are_not_uniforms():
    regions = get_technique("regions")
    p = regions.resolve({"lighting": "vertex", "ks": 0.5})
    u = regions.parameter_uniforms(p)
    assert u["u_ks"] == 0.5 and u["u_detail_strength"] == 0.6
    for name in CPU_PARAMS | regions.cpu_params:
        assert f"u_{name}" not in u
    splat = get_technique("splat")
    assert splat.parameter_uniforms(splat.resolve({"hex_tiling": True}))["u_hex_tiling"] == 1
    material = get_technique("material")
    u = material.parameter_uniforms(material.resolve({"flow": np.zeros((5, 5), np.float32)}))
    assert "u_flow" not in u and "u_hex_seed" in u


class _Renderer:
    def __init__(self, hm):
        self.heightmap = hm

    def regions(self, params):
        from terrascape.texture import default_regions

        return default_regions(self.heightmap) if params["regions"] is None else params["regions"]

    def tile_size(self, params):
        return 32.0


def test_region_hook_gives_the_region_table():
    from terrascape.texture import default_regions

    hm = Heightmap(np.linspace(0, 10, 81, dtype=np.float32).reshape(9, 9))
    tech = get_technique("regions")
    u = tech.uniforms(_Renderer(hm), tech.resolve({}))
    regions = default_regions(hm)
    assert u["u_n_regions"] == len(regions)
    np.testing.assert_allclose(u["u_region_max"][: len(regions)], [r.max for r in regions])
    assert u["u_detail_size"] == pytest.approx(32.0 / 5.0)
    assert tech.uniforms(_Renderer(hm), tech.resolve({"detail_size": 3.0}))["u_detail_size"] == 3
    with pytest.raises(InvalidParameterError, match="slope_rule"):
        tech.uniforms(_Renderer(hm), tech.resolve({"slope_rule": "steep"}))
    assert get_technique("splat").uniforms(_Renderer(hm), tech.resolve({})) == {
        "u_n_layers": len(regions)}


@pytest.mark.gl
def test_a_new_technique_is_one_entry_with_its_own_hook(gl_ctx):
    """A technique outside the built-in table: its hook's uniform and its CPU-side
    parameter reach the frame without the renderer knowing it (the colour of ``plain``
    scaled by ``u_gain`` from the hook; ``label`` is a string the program never sees)."""
    from terrascape.render.offscreen import OffscreenRenderer

    seen = []

    def gain(renderer, params):
        seen.append(params["label"])
        return {"u_kd": 0.5 * float(params["strength"])}

    tech = Technique(
        "half_plain", "terrain/plain",
        textures=(TextureSlot("u_color_tex", build_region_texture, depends=("seed", "regions")),),
        defaults={"strength": 1.0, "label": "not a number"},
        uniforms=gain, cpu_params=frozenset({"label"}))
    hm = Heightmap(np.zeros((17, 17), np.float32))
    r = OffscreenRenderer(gl_ctx, hm, size=(32, 32))
    try:
        cam = Camera.look_at((8.0, 30.0, 8.0), (8.0, 0.0, 8.0), fov_y=30.0, near=1.0, far=100.0)
        flat = {"sky": False, "fog_density": 0.0, "lighting": "vertex", "ka": 0.0,
                "sun": (0.0, 90.0)}
        full = r.render(cam, "plain", flat).astype(float)
        half = r.render(cam, tech, flat).astype(float)
        assert r.terrain.drawn_technique == "half_plain" and seen == ["not a number"]
        centre = (slice(12, 20), slice(12, 20), slice(0, 3))
        # kd 0.75 (plain's default) against 0.5 from the hook, in display (sRGB-ish) values
        assert half[centre].mean() < full[centre].mean() - 10
    finally:
        r.release()


def test_the_renderer_knows_no_technique_by_name():
    """terrain.py names no technique and no parameter of one technique: what is particular
    to a technique is on its entry (a new one needs no edit of the renderer)."""
    import inspect

    from terrascape.render import terrain
    from terrascape.render.techniques import COMMON_PARAMS

    source = inspect.getsource(terrain).replace('technique: str | Technique = "plain"', "")
    own = set()
    for name in technique_names():
        # ("regions" is also the common parameter of the height regions)
        assert name in COMMON_PARAMS or f'"{name}"' not in source, name
        own |= set(get_technique(name).defaults) - set(COMMON_PARAMS)
    for param in sorted(own):  # read as params["x"], params.get("x"), "x" in params
        for use in (f'["{param}"]', f'.get("{param}"', f'"{param}" in '):
            assert use not in source, param
