"""Shared fixtures: a seeded rng, a headless GL context and an Xvfb screen that skip —
except in CI, and a run of a call whose thread start is interrupted."""

from __future__ import annotations

import os
import pathlib
import select
import shutil
import subprocess
import sys

import numpy as np
import pytest

IN_CI = os.environ.get("CI", "").lower() in {"1", "true", "yes"}


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


# Ctrl-C landing in Thread.start once the thread has started (a pool then may not have
# registered it for the interpreter's exit), during ``CALL``; then, with "again", the same
# call once more, printed.
_INTERRUPTED_START = """
import sys
import threading
SETUP
start = threading.Thread.start

def interrupted(self):
    start(self)
    raise KeyboardInterrupt

threading.Thread.start = interrupted
try:
    CALL
except KeyboardInterrupt:
    print("interrupted", flush=True)
threading.Thread.start = start
if sys.argv[1] == "again":
    print(CALL, flush=True)
"""


@pytest.fixture
def interrupted_thread_start():
    """``run(setup, call, then, **env)``: the script above in a fresh interpreter (``then``
    "exit" or "again"); returns the finished process (a hang at exit times out)."""
    src = str(pathlib.Path(__file__).resolve().parents[1] / "src")

    def run(setup: str, call: str, then: str, **env: str) -> subprocess.CompletedProcess:
        script = _INTERRUPTED_START.replace("SETUP", setup).replace("CALL", call)
        return subprocess.run([sys.executable, "-c", script, then], capture_output=True,
                              text=True, env={**os.environ, "PYTHONPATH": src, **env},
                              timeout=120)

    return run


@pytest.fixture(scope="session")
def gl_ctx():
    """A headless OpenGL 3.3+ context (EGL/llvmpipe). Skips without GL, fails in CI."""
    try:
        from terrascape.render.context import create_headless_context

        ctx = create_headless_context()
    except Exception as exc:
        if IN_CI:
            pytest.fail(f"CI must have headless GL, but: {exc}")
        pytest.skip(f"no headless OpenGL: {exc}")
    yield ctx
    ctx.release()


@pytest.fixture
def xvfb() -> dict[str, str]:
    """The environment of a new Xvfb screen (640×480×24): ``DISPLAY`` set to the display
    Xvfb chose itself (``-displayfd``, so tests on two workers never share one). Skips
    without Xvfb, xdotool and ImageMagick's ``import`` — except in CI."""
    missing = [t for t in ("Xvfb", "xdotool", "import") if shutil.which(t) is None]
    if missing:
        if IN_CI:
            pytest.fail(f"CI must provide {', '.join(missing)} for the viewer test")
        pytest.skip(f"missing {', '.join(missing)}")
    read, write = os.pipe()
    # Xvfb writes its number again at each server reset (its last client leaving): to a
    # closed pipe that write killed it, so the pipe stays open until the end, and -noreset
    # spares the resets altogether
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-noreset", "-screen", "0", "640x480x24",
         "-nolisten", "tcp"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, pass_fds=(write,))
    os.close(write)
    try:
        # Xvfb writes the display number once it accepts clients (EOF if it fails to start)
        ready, _, _ = select.select([read], [], [], 20.0)
        number = os.read(read, 64).decode().strip() if ready else ""
        if not number.isdigit():
            proc.kill()
            proc.wait(5)
            pytest.fail("Xvfb did not start")
        yield dict(os.environ, DISPLAY=f":{number}")
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        os.close(read)


def _mesh_on_samples(tris: np.ndarray, z: np.ndarray, n: int, scale: int) -> np.ndarray:
    """A mesh of grid vertices (``n`` a side, heights ``z``, triangles of flat vertex
    indices) at every sample of the ``scale``× finer grid over the same square: each fine
    sample takes the first triangle that holds it (inclusive edges); NaN where none does."""
    m = (n - 1) * scale + 1
    out = np.full((m, m), np.nan)
    rr, cc = np.mgrid[0:m, 0:m] / scale
    for t in tris:
        (ar, ac), (br, bc), (cr, ccr) = (divmod(int(v), n) for v in t)
        det = (br - ar) * (ccr - ac) - (bc - ac) * (cr - ar)
        w1 = ((rr - ar) * (ccr - ac) - (cc - ac) * (cr - ar)) / det
        w2 = ((br - ar) * (cc - ac) - (bc - ac) * (rr - ar)) / det
        w0 = 1.0 - w1 - w2
        inside = (w0 >= -1e-9) & (w1 >= -1e-9) & (w2 >= -1e-9) & np.isnan(out)
        out[inside] = (w0 * z.flat[t[0]] + w1 * z.flat[t[1]] + w2 * z.flat[t[2]])[inside]
    return out


@pytest.fixture(scope="session")
def mesh_on_samples():
    """:func:`_mesh_on_samples`: a grid-vertex mesh evaluated on a finer grid's samples."""
    return _mesh_on_samples


def _box_mesh(size=(2.0, 6.0, 2.0), color=(0.45, 0.3, 0.2), name="box"):
    """An axis-aligned flat-shaded box (24 vertices, face normals) standing on the origin."""
    from terrascape.objects import ObjectMesh

    pos, nrm, tri = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)
            base = len(pos)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                pos.append(0.5 * (n + a * u + b * v))
                nrm.append(n)
            tri += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
    p = np.array(pos) * size + [0.0, size[1] / 2, 0.0]
    return ObjectMesh(name, p, np.array(nrm), np.tile(color, (len(p), 1)), np.array(tri))


@pytest.fixture(scope="session")
def box_mesh():
    """``box_mesh(size, color, name) -> ObjectMesh``: the test scenes' box (a fixture: with
    ``--import-mode=importlib`` test modules cannot import one another)."""
    return _box_mesh
