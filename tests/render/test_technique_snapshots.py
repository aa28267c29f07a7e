"""Every registered technique draws what it drew before the renderer was restructured.

Each case renders a small diamond-square terrain from one camera and compares the image
with statistics recorded from the renderer before its technique hooks, deferred module and
fallback decision were moved (``data/technique_snapshots.json``): the mean colour and a
4 × 4 grid of block means. A technique that loses a uniform, a texture or its deferred
pass changes them by far more than the tolerances; regenerate the file only for an
intended change of a picture (``python tests/render/test_technique_snapshots.py``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).with_name("data") / "technique_snapshots.json"
SIZE = (64, 48)
MEAN_TOLERANCE = 0.5  # 8-bit levels
BLOCK_TOLERANCE = 2.0


def cases() -> dict[str, tuple[str, dict, bool | None]]:
    """name -> (technique, parameters, deferred_shading): every technique as drawn by
    default (deferred where the technique is, on a software rasteriser) and forward, and
    the lighting modes of the techniques with a lightmap."""
    from terrascape.render.techniques import get_technique, technique_names

    out: dict[str, tuple[str, dict, bool | None]] = {}
    for name in technique_names():
        out[name] = (name, {}, None)
        if get_technique(name).deferred:
            out[f"{name}/forward"] = (name, {}, False)
    for mode in ("lightmap", "vertex", "none"):
        out[f"plain/{mode}"] = ("plain", {"lighting": mode}, None)
    out["regions/lightmap"] = ("regions", {"lighting": "lightmap"}, None)
    out["regions/no-slope-rule"] = ("regions", {"slope_rule": False, "detail_size": 2.0}, None)
    out["plain/wireframe"] = ("plain", {"wireframe": True}, None)
    out["material/sea"] = ("material", {"sea_level": 0.3}, None)
    out["bump/vertex"] = ("bump", {"bump_height": 2.0, "bump_strength": 0.5,
                                   "lighting": "vertex"}, None)
    return out


def terrain():
    from terrascape.generate import generate
    from terrascape.heightmap import Heightmap

    h = generate("diamond-square", 33, seed=3).heights
    h = (h - h.min()) / max(float(np.ptp(h)), 1e-6) * 6.0
    return Heightmap(h.astype(np.float32), spacing=(1.0, 1.0))


def render_case(renderers, ctx, hm, technique: str, params: dict, deferred) -> np.ndarray:
    from terrascape.render.offscreen import OffscreenRenderer
    from terrascape.render.techniques import get_technique

    r = renderers.get(deferred)
    if r is None:
        r = renderers[deferred] = OffscreenRenderer(ctx, hm, size=SIZE,
                                                    deferred_shading=deferred)
    base = {"shadow_samples": 2, "material_size": 64}
    if "relief_size" in get_technique(technique).parameters():
        base["relief_size"] = 64
    img = r.render(r.default_camera(elevation=35.0), technique, {**base, **params})
    assert r.terrain.drawn_technique == technique
    return img


def statistics(img: np.ndarray) -> dict:
    rgb = img[..., :3].astype(np.float64)
    blocks = rgb.reshape(4, SIZE[1] // 4, 4, SIZE[0] // 4, 3).mean(axis=(1, 3, 4))
    return {"mean": [round(float(v), 3) for v in rgb.mean(axis=(0, 1))],
            "blocks": [[round(float(v), 2) for v in row] for row in blocks]}


@pytest.fixture(scope="module")
def scene(gl_ctx):
    renderers: dict = {}
    yield renderers, gl_ctx, terrain()
    for r in renderers.values():
        r.release()


@pytest.mark.gl
@pytest.mark.parametrize("case", sorted(cases()))
def test_technique_draws_as_before(scene, case):
    expected = json.loads(DATA.read_text())
    assert case in expected, f"no recorded statistics for {case}; regenerate {DATA.name}"
    technique, params, deferred = cases()[case]
    got = statistics(render_case(*scene, technique, params, deferred))
    want = expected[case]
    np.testing.assert_allclose(got["mean"], want["mean"], atol=MEAN_TOLERANCE)
    np.testing.assert_allclose(got["blocks"], want["blocks"], atol=BLOCK_TOLERANCE)


def test_every_technique_has_a_recorded_picture():
    from terrascape.render.techniques import technique_names

    recorded = set(json.loads(DATA.read_text()))
    assert set(technique_names()) <= recorded
    assert set(cases()) == recorded


if __name__ == "__main__":  # regenerate the statistics (an intended change of a picture)
    from terrascape.render.context import create_headless_context

    ctx = create_headless_context()
    state = ({}, ctx, terrain())
    out = {name: statistics(render_case(*state, *spec)) for name, spec in cases().items()}
    lines = [f"{json.dumps(k)}: {json.dumps(v)}" for k, v in out.items()]
    DATA.write_text("{\n" + ",\n".join(lines) + "\n}\n")
    sys.exit(0)
