"""GLSL program loading: one ``.glsl`` file per program, ``#include`` resolution, ``#define``
injection, per-context program cache, and validated uniform upload.

Layout: as in the original program of the relief-texturing thesis, which keeps each effect
as one shader file and feeds its constants through a "shader constant callback" every
frame. Here:

* every program is ``render/shaders/<name>.glsl`` with sections::

      #if defined VERTEX_SHADER
      ...
      #elif defined GEOMETRY_SHADER   // optional
      ...
      #elif defined FRAGMENT_SHADER
      ...
      #endif

* ``#include "common/lighting.glsl"`` is resolved relative to the shader root (then to the
  including file's folder), recursively; a file included twice in one program is pasted once
  (``#pragma once`` semantics; each stage section of the program file counts on its own,
  as only one of them is compiled), a cycle or a missing file is an error;
* :func:`load_source` prepends ``#version 330 core``, the stage define, the ids of the relief
  tracers (``#define TECH_RELIEF 5`` …, from
  :data:`terrascape.render.techniques.RELIEF_TRACERS`: no ``.glsl`` file keeps the numbers)
  and user ``#define``s, and ``#line`` directives whose source-string numbers map back to
  file names in error logs;
* :func:`set_uniforms` is the constant callback: it validates each value (finite, right
  number of components) and silently skips uniforms the GLSL compiler optimised away, so one
  parameter dictionary can drive every technique.

References
----------
- D. Janković, "Reljefne tehnike teksturiranja u prikazu terena" (Relief texturing techniques
  in terrain rendering), MSc thesis 62, Faculty of Electrical Engineering and Computing,
  University of Zagreb, 2010, §2.6.
"""

from __future__ import annotations

import re
import weakref
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from terrascape.errors import FileFormatError, GLUnavailableError, InvalidParameterError
from terrascape.render.techniques import tracer_id_defines

SHADER_DIR = Path(__file__).resolve().parent / "shaders"
GLSL_VERSION = "#version 330 core"
STAGES = {
    "vertex": "VERTEX_SHADER",
    "geometry": "GEOMETRY_SHADER",
    "fragment": "FRAGMENT_SHADER",
}

_INCLUDE_RE = re.compile(r'^\s*#\s*include\s+"([^"]+)"\s*$')
_STAGE_RE = re.compile(r"^\s*#\s*(?:el)?if\s+defined\s*\(?\s*(?:VERTEX|GEOMETRY|FRAGMENT)_SHADER\b")
_IDENT_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class ShaderSourceError(FileFormatError):
    """A ``.glsl`` file or one of its includes is missing, or includes form a cycle."""


class ShaderCompileError(GLUnavailableError):
    """The GL driver rejected a program; the message carries the compiler/linker log."""


def program_path(name: str) -> Path:
    """Path of program ``name`` (``"terrain/plain"`` → ``shaders/terrain/plain.glsl``)."""
    return _resolve(name if name.endswith(".glsl") else f"{name}.glsl", None)


def available_programs() -> list[str]:
    """Names of every program file; files inside any folder named ``common`` (e.g.
    ``common/``, ``relief/common/``) are include files, not programs."""
    return sorted(
        p.relative_to(SHADER_DIR).with_suffix("").as_posix()
        for p in SHADER_DIR.rglob("*.glsl")
        if "common" not in p.relative_to(SHADER_DIR).parts[:-1]
    )


def _resolve(include: str, current: Path | None) -> Path:
    candidates = [SHADER_DIR / include]
    if current is not None:
        candidates.append(current.parent / include)
    for c in candidates:
        if c.is_file():
            return c.resolve()
    where = f" (included from {_rel(current)})" if current is not None else ""
    raise ShaderSourceError(
        f"shader file {include!r} not found{where}; looked in "
        + ", ".join(str(c.parent) for c in candidates)
    )


def _rel(path: Path | None) -> str:
    if path is None:
        return "?"
    try:
        return path.relative_to(SHADER_DIR).as_posix()
    except ValueError:
        return str(path)


def _expand(path: Path, stack: list[Path], done: set[Path], files: list[Path]) -> list[str]:
    """Source lines of ``path`` with includes pasted in, wrapped in ``#line`` directives."""
    if path in stack:
        chain = " -> ".join(_rel(p) for p in [*stack, path])
        raise ShaderSourceError(f"#include cycle: {chain}")
    if path in done:
        return []
    done.add(path)
    files.append(path)
    index = len(files) - 1
    stack.append(path)
    out = [f"#line 1 {index}"]
    shared: set[Path] | None = None  # pasted before the program's first stage section
    for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if len(stack) == 1 and _STAGE_RE.match(line):
            # Stage sections exclude each other: a file the vertex section pasted is pasted
            # again in the fragment section (only one of the two is compiled).
            if shared is None:
                shared = set(done)
            done.clear()
            done.update(shared)
        m = _INCLUDE_RE.match(line)
        if m:
            out.extend(_expand(_resolve(m.group(1), path), stack, done, files))
            out.append(f"#line {lineno + 1} {index}")
        else:
            out.append(line)
    stack.pop()
    return out


def _define_lines(defines: Mapping | None) -> list[str]:
    if not defines:
        return []
    if not isinstance(defines, Mapping):
        raise InvalidParameterError(f"defines must be a mapping name -> value, got {defines!r}")
    lines = []
    for key in sorted(defines):
        value = defines[key]
        if not isinstance(key, str) or not _IDENT_RE.match(key):
            raise InvalidParameterError(f"define name must be a GLSL identifier, got {key!r}")
        if value is None or value is True:
            lines.append(f"#define {key} 1" if value is True else f"#define {key}")
        elif value is False:
            lines.append(f"#define {key} 0")
        elif isinstance(value, (int, np.integer)):
            lines.append(f"#define {key} {int(value)}")
        elif isinstance(value, (float, np.floating)):
            if not np.isfinite(value):
                raise InvalidParameterError(f"define {key} must be finite, got {value!r}")
            lines.append(f"#define {key} {float(value)!r}")
        elif isinstance(value, str) and "\n" not in value:
            lines.append(f"#define {key} {value}")
        else:
            raise InvalidParameterError(
                f"define {key} must be None/bool/int/float/one-line str, got {value!r}"
            )
    return lines


def _source_and_files(name: str, stage: str, defines: Mapping | None) -> tuple[str, list[Path]]:
    if stage not in STAGES:
        raise InvalidParameterError(f"stage must be one of {sorted(STAGES)}, got {stage!r}")
    files: list[Path] = []
    body = _expand(program_path(name), [], set(), files)
    header = [GLSL_VERSION, f"#define {STAGES[stage]}", *_define_lines(tracer_id_defines()),
              *_define_lines(defines)]
    return "\n".join(header + body) + "\n", files


def load_source(name: str, stage: str, defines: Mapping | None = None) -> str:
    """Full GLSL source of one stage of program ``name``.

    Parameters
    ----------
    name
        Program path under ``render/shaders`` without ``.glsl`` (``"terrain/plain"``).
    stage
        ``"vertex"``, ``"geometry"`` or ``"fragment"``; selects the ``#if defined`` section.
    defines
        Extra ``#define NAME VALUE`` lines (``None`` value → bare ``#define NAME``).

    Raises
    ------
    ShaderSourceError
        Missing file or include, or include cycle (a :class:`FileFormatError`).
    InvalidParameterError
        Unknown stage or a bad define.
    """
    return _source_and_files(name, stage, defines)[0]


def _stages_of(name: str) -> set[str]:
    """Stages a program file provides (searches the file itself, not its includes)."""
    text = program_path(name).read_text(encoding="utf-8")
    return {stage for stage, macro in STAGES.items() if re.search(rf"\b{macro}\b", text)}


_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cache_key(name: str, defines: Mapping | None) -> tuple:
    items = tuple(sorted((str(k), repr(v)) for k, v in (defines or {}).items()))
    return (name, items)


def load_program(ctx, name: str, defines: Mapping | None = None):
    """Compile and link program ``name`` on ``ctx``; cached per (ctx, name, defines).

    Raises
    ------
    ShaderSourceError
        Source problems (see :func:`load_source`).
    ShaderCompileError
        The driver's compile/link log (a :class:`~terrascape.errors.GLUnavailableError`),
        with ``#line`` source numbers mapped to file names.
    """
    per_ctx = _CACHE.setdefault(ctx, {})
    key = _cache_key(name, defines)
    if key in per_ctx:
        return per_ctx[key]
    stages = _stages_of(name)
    if not {"vertex", "fragment"} <= stages:
        raise ShaderSourceError(
            f"program {name!r} must have VERTEX_SHADER and FRAGMENT_SHADER sections, "
            f"found {sorted(stages)}"
        )
    sources, legend = {}, {}
    for stage in stages:
        src, files = _source_and_files(name, stage, defines)
        sources[f"{stage}_shader"] = src
        legend.update({i: _rel(p) for i, p in enumerate(files)})
    try:
        program = ctx.program(**sources)
    except Exception as exc:  # moderngl.Error carries the driver log
        files = ", ".join(f"{i} = {f}" for i, f in sorted(legend.items()))
        raise ShaderCompileError(
            f"shader program {name!r} failed to compile/link (source numbers: {files}):\n{exc}"
        ) from None
    per_ctx[key] = program
    return program


def _flatten(name: str, value, uniform) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.int32)
    if not np.issubdtype(arr.dtype, np.number):
        raise InvalidParameterError(f"uniform {name} must be numeric, got {value!r}")
    dim = uniform.dimension
    side = {4: 2, 9: 3, 16: 4}.get(dim)
    # A square numpy matrix is in math (row-major, column-vector) convention; GL wants
    # column-major, so it is transposed — the same rule as Camera's `M.T.tobytes()`.
    if side is not None and arr.ndim >= 2 and arr.shape[-2:] == (side, side):
        arr = np.swapaxes(arr, -1, -2)
    flat = arr.astype(np.float64).ravel()
    if not np.isfinite(flat).all():
        raise InvalidParameterError(f"uniform {name} must be finite, got {value!r}")
    expected = dim * uniform.array_length
    if flat.size != expected:
        raise InvalidParameterError(
            f"uniform {name} expects {expected} component(s) "
            f"({uniform.array_length} × {dim}), got {flat.size}: {value!r}"
        )
    return flat


def set_uniforms(program, **values) -> list[str]:
    """Upload uniform values, validating each; returns the names actually set.

    Scalars, sequences and numpy arrays are accepted; square ``(n, n)`` arrays for ``matN``
    uniforms are math-convention matrices and are transposed to GL's column-major order;
    flat sequences are uploaded as given. ``bool`` becomes ``int``. Names the program does
    not have (optimised away, or used by another technique) are skipped silently.

    Raises
    ------
    InvalidParameterError
        NaN/inf, non-numeric value, or wrong number of components.
    """
    import moderngl

    done = []
    for name, value in values.items():
        if name not in program:
            continue
        uniform = program[name]
        if not isinstance(uniform, moderngl.Uniform):
            continue
        flat = _flatten(name, value, uniform)
        kind = (uniform.fmt or "f")[-1]
        dtype = {"i": np.int32, "I": np.uint32, "d": np.float64}.get(kind, np.float32)
        if dtype is not np.float32 and not np.all(flat == np.round(flat)):
            raise InvalidParameterError(f"uniform {name} is an integer uniform, got {value!r}")
        uniform.write(flat.astype(dtype).tobytes())
        done.append(name)
    return done


__all__ = [
    "GLSL_VERSION",
    "SHADER_DIR",
    "ShaderCompileError",
    "ShaderSourceError",
    "available_programs",
    "load_program",
    "load_source",
    "program_path",
    "set_uniforms",
]
