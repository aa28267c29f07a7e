"""The generator registry: the names every command offers, defaults with real relief, one
terrain per name and seed everywhere, aliases, parameters from the command line."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrascape.cli.app import run_app
from terrascape.errors import InvalidParameterError
from terrascape.generate import diamond_square, fbm, hills, square_square
from terrascape.generate.registry import (
    GENERATORS,
    default_relief,
    generate,
    generator_names,
    get_generator,
    names_help,
    parse_params,
)


def help_text(argv: list[str], capsys, monkeypatch) -> str:
    monkeypatch.setenv("COLUMNS", "500")  # no wrapping inside rich's boxes
    assert run_app([*argv, "--help"]) == 0
    return re.sub(r"\s+", " ", capsys.readouterr().out.replace("│", " "))


def test_generate_help_lists_exactly_the_registry(capsys, monkeypatch) -> None:
    monkeypatch.setenv("COLUMNS", "500")
    assert run_app(["generate", "--help"]) == 0
    text = capsys.readouterr().out
    commands = text[text.index("Commands"):]
    listed = re.findall(r"^│ (\S+) ", commands, flags=re.MULTILINE)
    assert tuple(listed) == generator_names() == ("diamond-square", "fault", "hills", "fbm",
                                                  "ridged")


@pytest.mark.parametrize("command", ["render", "view"])
def test_render_and_view_offer_the_registry_names(command, capsys, monkeypatch) -> None:
    text = help_text([command], capsys, monkeypatch)
    assert names_help() in text
    assert "--gen-param" in text and "--gen-size" in text and "--seed" in text


@pytest.mark.parametrize("name", generator_names())
def test_each_command_has_the_registry_parameters(name, capsys, monkeypatch) -> None:
    text = help_text(["generate", name], capsys, monkeypatch)
    for param in get_generator(name).params:
        assert param.option in text
        for choice in param.choices:
            assert choice in text


@pytest.mark.parametrize("name", generator_names())
@pytest.mark.parametrize(("shape", "spacing"), [(33, 1.5), ((33, 65), 2.0)])
def test_default_relief_is_a_fifth_of_the_extent(name, shape, spacing) -> None:
    if GENERATORS[name].square_pow2 and not isinstance(shape, int):
        with pytest.raises(InvalidParameterError, match="square"):
            generate(name, shape, seed=1, spacing=spacing)
        return
    hm = generate(name, shape, seed=1, spacing=spacing)
    extent = max((hm.cols - 1) * spacing, (hm.rows - 1) * spacing)
    assert default_relief(hm.shape, spacing) == pytest.approx(0.2 * extent)
    assert hm.min == pytest.approx(0.0, abs=1e-4)
    assert hm.max == pytest.approx(0.2 * extent, rel=1e-5)
    assert generate(name, shape, seed=1, spacing=spacing, relief=50.0).max == pytest.approx(50.0)


@pytest.mark.parametrize("name", generator_names())
def test_one_terrain_per_name_and_seed_everywhere(name) -> None:
    from terrascape.cli.cmd_render import _load
    from terrascape.cli.cmd_view import generate_terrain

    ref = generate(name, 33, seed=4, spacing=2.0)
    assert _load(None, name, 33, 4).heights.tobytes() == ref.heights.tobytes()
    assert generate_terrain(name, 33, 4).heights.tobytes() == ref.heights.tobytes()
    assert generate(name, 33, seed=5, spacing=2.0).heights.tobytes() != ref.heights.tobytes()


def test_variants_and_raw_heights() -> None:
    raw = generate("diamond-square", 65, seed=3, raw=True)
    assert raw.heights.tobytes() == square_square(65, seed=3).heights.tobytes()
    classic = generate("diamond-square", 65, seed=3, raw=True, variant="classic")
    assert classic.heights.tobytes() == diamond_square(65, seed=3).heights.tobytes()
    integer = generate("diamond-square", 33, roughness=255, integer=True, raw=True)
    assert integer.metadata["generator_params"]["variant"] == "classic"
    with pytest.raises(InvalidParameterError, match="classic"):
        generate("diamond-square", 33, integer=True, variant="square-square")
    noise = generate("fbm", (40, 50), seed=2, raw=True)
    plain = fbm((40, 50), scale=39 / 4, octaves=2, seed=2)  # side/4, down to ~4 samples
    assert noise.heights.tobytes() == plain.heights.tobytes()
    with pytest.raises(InvalidParameterError):
        generate("fbm", 33, raw=True, relief=10.0)


def test_hills_have_no_flat_floor_unless_asked() -> None:
    def floor_share(hm) -> float:
        return float(np.mean(hm.heights <= hm.min + 1e-6 * (hm.max - hm.min)))

    assert floor_share(generate("hills", 257, seed=1)) < 1e-3
    assert floor_share(generate("hills", 257, seed=1, floor=True)) > 0.05
    params = generate("hills", 257, seed=1, floor=True).metadata["generator_params"]
    plain = hills(257, count=params["count"], radius_range=(params["radius_min"],
                                                             params["radius_max"]), seed=1)
    assert generate("hills", 257, seed=1, floor=True, raw=True).heights.tobytes() == \
        plain.heights.tobytes()


def test_aliases_and_unknown_names(tmp_path) -> None:
    with pytest.warns(DeprecationWarning, match="diamond-square"):
        assert get_generator("diamond_square") is GENERATORS["diamond-square"]
    with pytest.raises(InvalidParameterError, match="--generate must be one of"):
        get_generator("volcano")
    out = tmp_path / "a.npy"
    assert run_app(["generate", "fault_formation", "--size", "17", "-o", str(out), "-q"]) == 0
    assert np.load(out).tobytes() == generate("fault", 17).heights.tobytes()


def test_parameters_from_the_command_line() -> None:
    assert parse_params("fbm", ["octaves=3", "gain = 0.6"]) == {"octaves": 3, "gain": 0.6}
    assert parse_params("hills", ["floor=yes", "radius-max=9"]) == {"floor": True,
                                                                   "radius_max": 9.0}
    assert parse_params("diamond-square", ["corners=1,2,3,4"]) == {"corners": (1, 2, 3, 4)}
    for bad in (["octaves"], ["octaves=x"], ["volume=3"], ["floor=maybe"], ["decay=cubic"]):
        with pytest.raises(InvalidParameterError):
            parse_params("fbm" if bad[0].startswith("oct") else "hills", bad)
    with pytest.raises(InvalidParameterError):
        parse_params("diamond-square", ["decay=cubic"])
    with pytest.raises(InvalidParameterError, match="has no parameter"):
        generate("fbm", 33, volume=3)


def test_render_cli_takes_gen_params(capsys, monkeypatch) -> None:
    from terrascape.cli.cmd_render import _load

    hm = _load(None, "fbm", 33, 2, ["octaves=2", "scale=8"])
    assert hm.heights.tobytes() == generate("fbm", 33, seed=2, spacing=2.0, octaves=2,
                                            scale=8.0).heights.tobytes()
    assert run_app(["render", "--generate", "fbm", "--gen-param", "nope=1", "-q"]) == 2
