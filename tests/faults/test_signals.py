"""SIGTERM, SIGINT and SIGHUP during a write: afterwards no temporary file is left and the
output is either the complete old pair or the complete new pair (checked byte for byte / by
reading it back); the exit code is 128 + N with the line "nothing was written"."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.io import read_heightmap, write_heightmap

SRC = str(pathlib.Path(__file__).resolve().parents[2] / "src")
ENV = {**os.environ, "PYTHONPATH": SRC}
#: The real console script (its name installs the start-up signal handlers).
SCRIPT = pathlib.Path(sys.executable).parent / "terrascape"

# A CLI run whose RAW writer pauses half-way through writing its temporary file, and says so
# on stdout, so the signal lands exactly mid-write.
SLOW_WRITER = """
import pathlib, sys, time
real = pathlib.Path.write_bytes
def slow(self, data):
    real(self, bytes(data)[: len(data) // 2])
    print("writing", flush=True)
    time.sleep(30)
    real(self, data)
pathlib.Path.write_bytes = slow
from terrascape.cli import main
main()
"""


@pytest.fixture
def old_pair(tmp_path):
    write_heightmap(Heightmap(np.arange(256, dtype=np.float32).reshape(16, 16)), tmp_path / "o.r16")
    np.save(tmp_path / "src.npy", np.random.default_rng(0).random((1500, 1500), dtype=np.float32))
    return {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name.startswith("o.")}


def _outputs(folder) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir() if p.name != "src.npy"}


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP])
def test_signal_mid_write_removes_temporaries_and_keeps_old_pair(tmp_path, old_pair, sig):
    proc = subprocess.Popen(
        [sys.executable, "-c", SLOW_WRITER, "convert", str(tmp_path / "src.npy"),
         str(tmp_path / "o.r16"), "--force"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )
    assert proc.stdout.readline().strip() == "writing"
    temps = [p.name for p in tmp_path.iterdir() if ".part" in p.name]
    assert temps, "the temporary file exists while writing"
    proc.send_signal(sig)
    _out, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig
    assert f"interrupted ({signal.Signals(sig).name}); nothing was written" in err
    assert "Traceback" not in err
    assert _outputs(tmp_path) == old_pair  # old pair byte for byte, no temporary file


@pytest.mark.skipif(not SCRIPT.exists(), reason="no terrascape console script next to python")
@pytest.mark.parametrize("run", range(4))
def test_signal_at_a_random_moment_leaves_old_or_new_pair(tmp_path, old_pair, run):
    rng = np.random.default_rng(100 + run)
    sig = (signal.SIGTERM, signal.SIGINT)[run % 2]
    proc = subprocess.Popen(
        [str(SCRIPT), "convert",
         str(tmp_path / "src.npy"), str(tmp_path / "o.r16"), "--force"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )
    time.sleep(float(rng.uniform(0.05, 3.0)))  # from the imports to the final rename
    proc.send_signal(sig)
    _out, err = proc.communicate(timeout=60)
    # -sig: the signal came while the interpreter itself started, before any terrascape
    # code ran (Python's own default handlers); nothing can have been written then.
    assert proc.returncode in (0, 128 + sig, -sig), err
    if proc.returncode != -sig:
        assert "Traceback" not in err
    files = _outputs(tmp_path)
    assert sorted(files) == ["o.r16", "o.r16.json"]  # no temporary file in any case
    if files != old_pair:  # then it is the complete new pair: the hash in the sidecar agrees
        hm = read_heightmap(tmp_path / "o.r16")
        assert hm.heights.shape == (1500, 1500)
        src = np.load(tmp_path / "src.npy")
        assert np.abs(hm.heights - src).max() <= 0.5 / 65535 * float(np.ptp(src)) + 1e-6
    else:
        assert proc.returncode in (128 + sig, -sig)


def _signal_during(tmp_path, side: int, command: list[str], sig: int) -> float:
    """Run ``terrascape <command>`` on a ``side``² noise map ``in.npy``, send ``sig`` 1.5 s
    after the map was read (inside the command's long compiled work), check the exit code,
    the line and that nothing was written, and return how long the exit took."""
    src = tmp_path / "in.npy"
    np.save(src, (np.random.default_rng(5).random((side, side)) * 100).astype(np.float32))
    proc = subprocess.Popen(
        [sys.executable, "-c", "from terrascape.cli import main; main()", command[0],
         str(src), *command[1:]],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )
    # "read… 0.01 s": the work starts now
    _out, err, waited = _interrupt(proc, sig, 1.5, (proc.stderr, "read"))
    assert proc.returncode == 128 + sig, err
    assert f"interrupted ({signal.Signals(sig).name}); nothing was written" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.npy"]
    return waited


def test_ctrl_c_stops_a_long_erosion_within_seconds(tmp_path):
    """20 M droplets run for minutes; in chunks from Python, Ctrl-C is handled between two
    chunks instead of after the whole compiled loop."""
    waited = _signal_during(tmp_path, 257, ["erode", str(tmp_path / "out.npy"),
                                            "--hydraulic", "20000000"], signal.SIGINT)
    # One compiled call for all droplets ignored Ctrl-C for about a minute; now the wait is
    # one chunk plus the interpreter's exit (generous: the test host is shared and loaded).
    assert waited < 10.0, f"Ctrl-C took {waited:.1f} s"


def test_signal_while_the_second_of_two_outputs_is_written_leaves_neither(tmp_path, capsys,
                                                                         monkeypatch):
    """generate -o X --preview P, the signal arrives while P is written: the two are one
    unit, so X is not left alone either (nor its spacing sidecar), and with --force over an
    earlier X the earlier bytes stay. Exit 143, "nothing was written"."""
    import terrascape.cli.cmd_generate
    from terrascape.cli.app import run_app
    from terrascape.errors import Interrupted
    from terrascape.io.atomic import atomic_output

    def interrupted_preview(hm, path, *, force=False):
        with atomic_output(path, force=force) as tmp:
            tmp.write_bytes(b"half a preview")
            raise Interrupted(signal.SIGTERM)

    out, preview = tmp_path / "hm.npy", tmp_path / "p.png"
    argv = ["generate", "diamond-square", "--size", "33", "-o", str(out), "--preview",
            str(preview), "-q"]
    monkeypatch.setattr(terrascape.cli.cmd_generate, "write_preview", interrupted_preview)
    code = run_app(argv)
    err = capsys.readouterr().err
    assert code == 143
    assert "interrupted (SIGTERM); nothing was written" in err and "kept" not in err
    assert list(tmp_path.iterdir()) == []

    monkeypatch.undo()
    assert run_app([*argv[:-1], "--seed", "7", "-q"]) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert sorted(before) == ["hm.npy", "hm.npy.json", "p.png"]
    monkeypatch.setattr(terrascape.cli.cmd_generate, "write_preview", interrupted_preview)
    assert run_app([*argv, "--force"]) == 143
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


def test_signal_after_finished_demo_files_says_what_was_kept(tmp_path, capsys, monkeypatch):
    """The demo writes its files one by one: interrupted in its texture stage, the line
    names the generate stage's files, which stay complete, and exits 143."""
    import terrascape.cli.demo
    from terrascape.cli.app import run_app
    from terrascape.errors import Interrupted
    from terrascape.io import read_heightmap

    def interrupted_stage(*args, **kwargs):
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(terrascape.cli.demo, "texture_stage", interrupted_stage)
    code = run_app(["demo", "-o", str(tmp_path), "--size", "33", "--stages",
                    "generate,texture"])
    err = capsys.readouterr().err
    assert code == 143
    assert "interrupted (SIGTERM); finished before the signal and kept:" in err
    written = sorted(p for p in tmp_path.iterdir() if p.is_file())
    assert written and all(p.name in err for p in written)
    heightmaps = [p for p in written if p.name.endswith("_heightmap.png")]
    assert heightmaps and all(read_heightmap(p).shape == (33, 33) for p in heightmaps)
    assert not [p for p in written if ".part" in p.name]


def test_a_signal_stops_a_long_one_order_mesh_within_seconds(tmp_path):
    """A greedy TIN in one order is one compiled call of half a minute on a 2049² map at
    error 0; it runs on a worker thread while the main thread waits, so SIGTERM is handled at
    once, and the mesher, told to stop, ends within an insertion."""
    from terrascape.lod.greedy_tin import greedy_tin

    # compiled (or loaded) here first: a cold cache would make the run below compile for
    # most of a minute before the signal could be answered
    greedy_tin(Heightmap(np.eye(9, dtype=np.float32)), max_error=0.0, in_pieces=False)
    waited = _signal_during(tmp_path, 2049, ["mesh", "-o", str(tmp_path / "out.ply"),
                                             "--mesher", "greedy", "--max-error", "0",
                                             "--one-piece"], signal.SIGTERM)
    # before, the signal waited for the whole insertion (about 30 s; generous bound: the
    # test host is shared)
    assert waited < 10.0, f"SIGTERM took {waited:.1f} s"


# A compiled call that returns arrays, with a signal arriving while it runs, under the
# CLI's handlers.
SIGNAL_IN_A_KERNEL = """
import os, signal, threading, time
import numpy as np
from numba import njit
from terrascape.cli.app import _signals_raise
from terrascape.errors import Interrupted

@njit(nogil=True)
def spin(n):
    counts = np.zeros(10, np.int64)
    other = np.zeros(5, np.float32)
    total = 0
    for i in range(n):
        total += (i * 7) % 13
        counts[i % 10] += 1
    return counts, other, total

spin(10)  # compiled
t0 = time.perf_counter()
spin(10_000_000)
n = int(10_000_000 * 1.0 / max(time.perf_counter() - t0, 1e-6))  # about a second
returned = False
with _signals_raise():
    try:
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGTERM)).start()
        counts, _, _ = spin(n)
        returned = int(counts.sum()) == n
        time.sleep(5)
        print("no signal")
    except Interrupted as exc:
        print("interrupted", exc.signum, "after the call returned:", returned)
"""


def test_a_signal_during_a_compiled_call_is_handled_after_it_returns(tmp_path):
    """numba turns the call's result into Python objects in C code that cannot pass on an
    exception: raised there, the interruption became a SystemError with a traceback (or a
    crash). The CLI's handler sends the signal again, handled once the call has returned."""
    proc = subprocess.run([sys.executable, "-c", SIGNAL_IN_A_KERNEL], capture_output=True,
                          text=True, env=ENV, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == f"interrupted {int(signal.SIGTERM)} after the call returned: True"
    assert "Error" not in proc.stderr


# A signal handled inside a callback from C (ctypes), and inside a finaliser, under the
# CLI's handlers: Python prints such an exception as "Exception ignored" and drops it.
SIGNAL_IN_A_CALLBACK = """
import ctypes, gc, os, signal, time
from terrascape.cli.app import _signals_raise
from terrascape.errors import Interrupted

def busy():  # the handler runs at one of these bytecodes, inside the callback
    for _ in range(100_000):
        pass

@ctypes.CFUNCTYPE(None)
def callback():
    os.kill(os.getpid(), signal.SIGTERM)
    busy()

class Finalised:
    def __del__(self):
        os.kill(os.getpid(), signal.SIGTERM)
        busy()

for name, make_the_call in (("callback", callback), ("finaliser", lambda: Finalised())):
    with _signals_raise():
        start = time.perf_counter()
        try:
            make_the_call()
            gc.collect()
            # short sleeps: a signal that lands just before a blocking call begins waits
            # for its end (CPython checks for signals before it, not during it)
            for _ in range(500):
                time.sleep(0.01)
            print(name, "no signal")
        except Interrupted as exc:
            waited = time.perf_counter() - start
            print(name, "interrupted", exc.signum, "within 2 s:", waited < 2.0)
"""


def test_a_signal_in_a_callback_from_c_or_a_finaliser_is_not_lost():
    """numba's compiler calls back from C for every kernel it loads from its cache or
    compiles, for most of a command's first second; Python drops an exception raised in
    such a callback, or in a ``__del__``. A signal handled there was lost: SIGTERM while
    `render --day-cycle` loaded its kernels ended with exit 0 and the video written (3 runs
    of 40). The CLI's hook sends the dropped signal again, handled once the callback has
    returned."""
    proc = subprocess.run([sys.executable, "-c", SIGNAL_IN_A_CALLBACK], capture_output=True,
                          text=True, env=ENV, timeout=120)
    assert proc.returncode == 0, proc.stderr
    term = int(signal.SIGTERM)
    assert proc.stdout.split("\n")[:2] == [f"callback interrupted {term} within 2 s: True",
                                           f"finaliser interrupted {term} within 2 s: True"]
    assert "Exception ignored" not in proc.stderr and "Error" not in proc.stderr


SIGNAL_IN_LLVMLITE = """
import os, signal, time
from terrascape.cli.app import _signals_raise
from terrascape.errors import Interrupted

# a step of numba's compiler (llvmlite) that frees an object and then marks it freed
SOURCE = "\\n".join([
    "def close(state):",
    "    os.kill(os.getpid(), signal.SIGTERM)",
    "    state.append('freed')",
    "    for _ in range(100_000):  # the handler runs at one of these bytecodes",
    "        pass",
    "    state.append('marked')",
])
steps = {"os": os, "signal": signal}
exec(compile(SOURCE, os.path.join(os.sep, "venv", "llvmlite", "binding", "ffi.py"), "exec"),
     steps)
state = []
with _signals_raise():
    try:
        steps["close"](state)
        for _ in range(500):
            time.sleep(0.01)
        print("no signal")
    except Interrupted as exc:
        print("interrupted", exc.signum, "after", state)
"""


def test_a_signal_never_cuts_a_step_of_numbas_compiler_in_two():
    """llvmlite frees its objects in steps: an exception between "freed" and "marked"
    left an object that its finaliser freed again at the interpreter's exit (a segmentation
    fault, or an AttributeError traceback, after "nothing was written"). A signal handled
    in llvmlite's code is sent again and raised after the step."""
    proc = subprocess.run([sys.executable, "-c", SIGNAL_IN_LLVMLITE], capture_output=True,
                          text=True, env=ENV, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == (f"interrupted {int(signal.SIGTERM)} after "
                                   "['freed', 'marked']")


@pytest.mark.parametrize("model", ["thermal", "grid"])
def test_a_signal_stops_a_long_erosion_in_one_compiled_run_within_seconds(tmp_path, model):
    """The thermal and grid models make all their iterations in one compiled run (about a
    minute here): it runs on a worker thread while the main thread waits, so SIGTERM is
    handled at once, and the run, told to stop, ends before its next iteration."""
    waited = _signal_during(tmp_path, 513, ["erode", str(tmp_path / "out.npy"), "--model",
                                            model, "-n", "8000"], signal.SIGTERM)
    # before, the signal waited for every iteration (generous bound: the host is shared)
    assert waited < 10.0, f"SIGTERM took {waited:.1f} s"


def _interrupt(proc, sig: int, delay: float, first_line=None) -> tuple[str, str, float]:
    """Wait for the child's first line on a stream, when ``first_line`` is ``(stream,
    prefix)`` (it says its long work begins), and ``delay`` seconds more; send ``sig`` and
    return the child's stdout and stderr and the seconds it took to exit (killed on any
    failure)."""
    try:
        if first_line is not None:
            stream, prefix = first_line
            line = stream.readline()
            assert line.startswith(prefix), line
        time.sleep(delay)
        assert proc.poll() is None, proc.stderr.read()
        start = time.perf_counter()
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=120)
        return out, err, time.perf_counter() - start
    finally:
        proc.kill()


# Ctrl-C in a library call (a notebook's interrupt button sends the same signal): the call
# (after a first one that compiles or loads it) is about 10-30 s here.
CTRL_C_IN_A_LIBRARY_CALL = """
import signal
import sys
import numpy as np
from terrascape.analysis.drainage import breach_depressions
from terrascape.filters import gaussian_blur
from terrascape.filters.resample import resample_cubic
from terrascape.generate import fbm
from terrascape.lighting import shadow_mask_reference, sky_view_factor
from terrascape.relief import footprint_cone_map
from terrascape.relief.fields import natural_field

# a test run started in the background hands SIGINT down ignored, and Python then leaves it so
signal.signal(signal.SIGINT, signal.default_int_handler)
call, make = {"sky-view": (sky_view_factor, lambda n: fbm(n, seed=3)),
              "breach": (breach_depressions, lambda n: fbm(n, seed=3)),
              "cone-map": (footprint_cone_map, natural_field),
              # one ray per sample, most of them lit (long walks) on a smooth map
              "shadow-rays": (lambda h: shadow_mask_reference(h, 135.0, 45.0),
                              lambda n: fbm(n, scale=(n - 1) / 4, octaves=8,
                                            seed=3).normalised(0.0, 0.2 * (n - 1))),
              "blur": (lambda h: gaussian_blur(h, 150.0), lambda n: fbm(n, seed=3)),
              "resample": (lambda h: resample_cubic(h, (3 * h.shape[0] - 2, 3 * h.shape[1] - 2)),
                           lambda n: fbm(n, seed=3))}[sys.argv[1]]
call(np.random.default_rng(3).random((16, 16)))
heights = make(int(sys.argv[2]))
print("ready", flush=True)
try:
    call(heights)
    print("finished")
except KeyboardInterrupt:
    print("KeyboardInterrupt", flush=True)
"""


# the cone map's delay lets its numpy preparation (about a second; several seconds, and
# under load more than the delay, while it reduced a stack of the four corners) end first:
# Ctrl-C then lands in the compiled search (a search not handed over took 26.1 s); the
# resample's lands where one scipy zoom call (the resample before its bands) was past its
# interruptible first steps (Ctrl-C took 22.5 s)
@pytest.mark.parametrize(("call", "side", "delay"),
                         [("sky-view", 2049, 1.0), ("breach", 4097, 1.0),
                          ("cone-map", 4096, 5.0), ("shadow-rays", 4097, 1.0),
                          ("blur", 4097, 1.0), ("resample", 4097, 6.0)])
def test_ctrl_c_stops_a_long_library_call_at_once(call, side, delay):
    """The sky-view factor of a 2049² map, the drainage of a 4097² one, the relief cone
    map of a 4096² natural texture (about half a minute), the shadows of a 4097² map by
    one ray per sample (about 20 s), a Gaussian blur of σ = 150 on a 4097² map (about
    10 s on two threads), or a 4097² map resampled to 12289² (about 9 s on two threads):
    Ctrl-C during it raises KeyboardInterrupt at once, not after the call (nor a
    SystemError from numba's conversion of a result), and the interpreter exits."""
    proc = subprocess.Popen([sys.executable, "-c", CTRL_C_IN_A_LIBRARY_CALL, call, str(side)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    out, err, waited = _interrupt(proc, signal.SIGINT, delay, (proc.stdout, "ready"))
    assert out.strip() == "KeyboardInterrupt", err
    assert proc.returncode == 0 and "Error" not in err
    assert waited < 6.0, f"Ctrl-C took {waited:.1f} s"


def test_nested_signal_handlers_pass_other_dropped_exceptions_on_once():
    """A command run inside another's handlers (``run_app`` called in-process) installs the
    dropped-signal hook once: another dropped exception reaches the hook that was there
    before exactly once (installed twice, the hook passed it on to itself for ever)."""
    import threading
    import types

    from terrascape.cli.app import _signals_raise

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers are installed from the main thread only")
    seen = []
    recorder = seen.append
    previous = sys.unraisablehook
    sys.unraisablehook = recorder
    try:
        with _signals_raise():
            with _signals_raise():
                assert sys.unraisablehook is not recorder
                sys.unraisablehook(types.SimpleNamespace(exc_value=ValueError("dropped")))
            assert sys.unraisablehook is not recorder
        assert sys.unraisablehook is recorder
    finally:
        sys.unraisablehook = previous
    assert [str(u.exc_value) for u in seen] == ["dropped"]
