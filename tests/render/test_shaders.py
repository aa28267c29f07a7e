"""GLSL loading: includes, defines, caching, compile errors, uniform validation."""

from __future__ import annotations

import numpy as np
import pytest

from terrascape.errors import FileFormatError, GLUnavailableError, InvalidParameterError
from terrascape.render import shaders
from terrascape.render.shaders import (
    ShaderCompileError,
    ShaderSourceError,
    available_programs,
    load_program,
    load_source,
    set_uniforms,
)


@pytest.fixture
def shader_dir(tmp_path, monkeypatch):
    monkeypatch.setattr(shaders, "SHADER_DIR", tmp_path)
    (tmp_path / "common").mkdir()
    return tmp_path


def _write(root, rel, text):
    p = root / rel
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)
    return p


def test_source_has_version_stage_defines_and_includes(shader_dir):
    _write(shader_dir, "common/a.glsl", '#include "common/b.glsl"\nfloat a() { return b(); }\n')
    _write(shader_dir, "common/b.glsl", "float b() { return 1.0; }\n")
    _write(
        shader_dir,
        "prog.glsl",
        '#include "common/a.glsl"\n#include "common/b.glsl"\n'
        "#if defined VERTEX_SHADER\nvoid main(){}\n#endif\n",
    )
    src = load_source("prog", "vertex", {"N_LAYERS": 4, "FLAG": None, "K": 0.5})
    lines = src.splitlines()
    assert lines[0] == "#version 330 core"
    assert "#define VERTEX_SHADER" in lines
    assert "#define N_LAYERS 4" in lines and "#define FLAG" in lines
    assert "#define K 0.5" in lines
    # b is pasted once although included twice (diamond), before a's body
    assert src.count("float b()") == 1
    assert src.index("float b()") < src.index("float a()")
    assert "#include" not in src


def test_relief_tracer_ids_come_from_the_python_table(gl_ctx):
    """Every program gets ``#define TECH_<NAME> id`` from RELIEF_TRACERS, and no shader
    file keeps its own copy: the tracer a program compiles is the one the table names."""
    from terrascape.render.relief_quad import technique_id
    from terrascape.render.techniques import RELIEF_TRACERS

    lines = load_source("relief/quad", "fragment", {"TECHNIQUE": 5}).splitlines()
    for name, tid in RELIEF_TRACERS.items():
        assert lines.count(f"#define TECH_{name.upper()} {tid}") == 1
    assert technique_id("relief") == RELIEF_TRACERS["relief"]
    for path in shaders.SHADER_DIR.rglob("*.glsl"):
        assert "#define TECH_" not in path.read_text(), path
    # the ids select the tracer: the cone tracer's id compiles the cone map in, plain's not
    cone = load_program(gl_ctx, "relief/quad", {"TECHNIQUE": RELIEF_TRACERS["cone"]})
    plain = load_program(gl_ctx, "relief/quad", {"TECHNIQUE": RELIEF_TRACERS["plain"]})
    assert "u_cone" in cone and "u_cone" not in plain


def test_each_stage_section_pastes_its_own_includes(shader_dir):
    _write(shader_dir, "common/top.glsl", "float top() { return 1.0; }\n")
    _write(shader_dir, "common/both.glsl", "float both() { return 2.0; }\n")
    _write(shader_dir, "common/vs.glsl", '#include "common/both.glsl"\n')
    _write(
        shader_dir,
        "prog.glsl",
        '#include "common/top.glsl"\n'
        '#if defined VERTEX_SHADER\n#include "common/vs.glsl"\nvoid main(){}\n'
        '#elif defined FRAGMENT_SHADER\n#include "common/top.glsl"\n'
        '#include "common/both.glsl"\nvoid main(){}\n#endif\n',
    )
    src = load_source("prog", "fragment")
    # the vertex section's include is pasted again for the fragment section (only one
    # section compiles); what came before the sections stays pasted once
    assert src.count("float both()") == 2
    assert src.count("float top()") == 1


def test_missing_include_is_clear(shader_dir):
    _write(shader_dir, "prog.glsl", '#include "common/nope.glsl"\n')
    with pytest.raises(ShaderSourceError, match=r"nope\.glsl.*not found.*prog\.glsl"):
        load_source("prog", "fragment")
    with pytest.raises(FileFormatError, match="not found"):
        load_source("missing_program", "fragment")


def test_include_cycle_is_clear(shader_dir):
    _write(shader_dir, "common/x.glsl", '#include "common/y.glsl"\n')
    _write(shader_dir, "common/y.glsl", '#include "common/x.glsl"\n')
    _write(shader_dir, "prog.glsl", '#include "common/x.glsl"\n')
    with pytest.raises(
        ShaderSourceError,
        match=r"cycle: prog\.glsl -> common/x\.glsl -> "
        r"common/y\.glsl -> common/x\.glsl",
    ):
        load_source("prog", "vertex")


@pytest.mark.parametrize(
    "defines", [{"1BAD": 1}, {"X": float("nan")}, {"X": "a\nb"}, {"X": [1]}, "X"]
)
def test_bad_defines(defines):
    with pytest.raises(InvalidParameterError):
        load_source("debug/solid", "vertex", defines)


def test_bad_stage():
    with pytest.raises(InvalidParameterError, match="stage"):
        load_source("debug/solid", "tessellation")


@pytest.mark.gl
def test_every_shipped_program_compiles_and_links(gl_ctx):
    names = available_programs()
    assert "debug/solid" in names
    assert not any(n.startswith("common/") for n in names)
    for name in names:
        prog = load_program(gl_ctx, name)
        assert prog.glo > 0, name


@pytest.mark.gl
def test_program_cache_per_defines(gl_ctx):
    a = load_program(gl_ctx, "debug/solid")
    assert load_program(gl_ctx, "debug/solid") is a
    b = load_program(gl_ctx, "debug/solid", {"UNUSED_FLAG": 1})
    assert b is not a


@pytest.mark.gl
def test_compile_error_carries_log_and_file_names(gl_ctx, shader_dir):
    _write(shader_dir, "common/bad.glsl", "float broken() { return undeclared_thing; }\n")
    _write(
        shader_dir,
        "badprog.glsl",
        '#include "common/bad.glsl"\n#if defined VERTEX_SHADER\nvoid main(){}\n'
        "#elif defined FRAGMENT_SHADER\nout vec4 c; void main(){ c = vec4(broken()); }\n#endif\n",
    )
    with pytest.raises(ShaderCompileError, match=r"undeclared_thing") as info:
        load_program(gl_ctx, "badprog")
    assert isinstance(info.value, GLUnavailableError)
    assert "common/bad.glsl" in str(info.value)


@pytest.mark.gl
def test_program_without_fragment_section_is_refused(gl_ctx, shader_dir):
    _write(shader_dir, "vsonly.glsl", "#if defined VERTEX_SHADER\nvoid main(){}\n#endif\n")
    with pytest.raises(ShaderSourceError, match="FRAGMENT_SHADER"):
        load_program(gl_ctx, "vsonly")


@pytest.mark.gl
def test_set_uniforms_validates_and_skips_missing(gl_ctx):
    prog = load_program(gl_ctx, "debug/solid")
    m = np.arange(16, dtype=np.float64).reshape(4, 4)
    done = set_uniforms(prog, u_view_proj=m, u_color=(0.25, 0.5, 0.75, 1.0), u_absent=7)
    assert done == ["u_view_proj", "u_color"]
    # the math-convention matrix is stored column-major (transposed)
    stored = np.frombuffer(prog["u_view_proj"].read(), dtype=np.float32)
    np.testing.assert_array_equal(stored, m.T.ravel())
    assert prog["u_color"].value == pytest.approx((0.25, 0.5, 0.75, 1.0))
    with pytest.raises(InvalidParameterError, match="expects 4 component"):
        set_uniforms(prog, u_color=(1.0, 0.0, 0.0))
    with pytest.raises(InvalidParameterError, match="finite"):
        set_uniforms(prog, u_color=(1.0, float("nan"), 0.0, 1.0))
    with pytest.raises(InvalidParameterError, match="numeric"):
        set_uniforms(prog, u_color="red")
