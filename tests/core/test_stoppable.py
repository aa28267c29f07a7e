"""Long compiled calls on a worker thread, stopped by a signal: where they run, with how many
numba threads, and that the caller's exception waits for the kernel to end."""

from __future__ import annotations

import gc
import os
import pathlib
import signal
import threading
import time
import weakref
from concurrent.futures import Future

import numba
import numpy as np
import pytest

from terrascape import _stoppable
from terrascape._stoppable import run_stoppable

SRC = str(pathlib.Path(__file__).resolve().parents[2] / "src")


def _where(tag, stop):
    return threading.current_thread(), numba.get_num_threads(), tag, int(stop[0])


def test_a_long_call_from_the_main_thread_runs_on_the_worker_thread():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the test runner does not run tests on the main thread")
    thread, _, tag, stop = run_stoppable(True, _where, "x")
    assert thread is not threading.main_thread()
    assert thread.name == "terrascape-long"
    assert (tag, stop) == ("x", 0)


def test_a_short_call_or_one_from_another_thread_runs_where_it_is_called():
    assert run_stoppable(False, _where, "y")[0] is threading.current_thread()
    seen = []
    callers = [threading.Thread(target=lambda: seen.append(run_stoppable(True, _where, "z")))
               for _ in range(2)]
    for t in callers:
        t.start()
    for t in callers:
        t.join()
    assert {s[0] for s in seen} == set(callers)


def test_the_pool_thread_uses_the_callers_number_of_numba_threads():
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the test runner does not run tests on the main thread")
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        thread, threads, _, _ = run_stoppable(True, _where, "one")
        assert thread is not threading.main_thread()
        assert threads == 1
        numba.set_num_threads(before)
        assert run_stoppable(True, _where, "all")[1] == before
    finally:
        numba.set_num_threads(before)


def test_an_interrupted_wait_stops_the_kernel_and_waits_for_it():
    """Ctrl-C while waiting: the flag is set, the caller waits until the kernel has seen it
    and ended, and the KeyboardInterrupt goes on."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signals are only handled on the main thread")
    ended = threading.Event()

    def spin(stop):
        deadline = time.monotonic() + 30.0
        while not stop[0] and time.monotonic() < deadline:
            time.sleep(0.001)
        time.sleep(0.2)  # the caller must wait for this too
        ended.set()

    # Python's own Ctrl-C handler, whatever the test runner installed
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        start = time.monotonic()
        with pytest.raises(KeyboardInterrupt):
            run_stoppable(True, spin)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert ended.is_set()  # the kernel had ended when the exception reached us
    assert time.monotonic() - start < 10.0


def test_a_forked_child_makes_its_own_worker():
    _stoppable._worker()
    pid = os.fork()
    if pid == 0:  # the child: a worker of its own, whose thread runs
        ok = False
        try:
            ok = _stoppable._worker() is not _stoppable._WORKERS.get(os.getppid())
            future = Future()
            _stoppable._worker().submit(future, lambda: 7)
            ok = ok and future.result(timeout=10) == 7
        finally:
            os._exit(0 if ok else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0


def test_a_kernel_that_holds_the_gil_is_refused():
    """The waiting thread could not handle a signal while such a kernel runs."""

    @numba.njit
    def holds(stop):
        return stop[0]

    with pytest.raises(TypeError, match="nogil"):
        run_stoppable(True, holds)
    assert run_stoppable(False, holds) == 0  # on the calling thread it does not matter


def test_a_signal_during_the_workers_start_does_not_hang_the_exit(interrupted_thread_start):
    """Ctrl-C landing in the start of the worker's thread, then the interpreter's exit:
    with a ThreadPoolExecutor, whose thread was not yet registered for its shutdown, the
    exit waited for that thread for ever."""
    for then, said in (("exit", ["interrupted"]), ("again", ["interrupted", "ran"])):
        proc = interrupted_thread_start("from terrascape._stoppable import run_stoppable",
                                        'run_stoppable(True, lambda stop: "ran")', then)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.split() == said


def test_a_call_interrupted_before_the_worker_began_it_is_cancelled(monkeypatch):
    """A signal right after the hand-over: the worker does not run the call later."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the test runner does not run tests on the main thread")
    ran = []
    worker = _stoppable._worker()
    submit = worker.submit
    gate = threading.Event()
    blocker = Future()
    submit(blocker, gate.wait)  # the worker is busy until the gate opens

    def interrupted_submit(future, call):
        submit(future, call)
        raise KeyboardInterrupt

    monkeypatch.setattr(worker, "submit", interrupted_submit)
    with pytest.raises(KeyboardInterrupt):
        run_stoppable(True, lambda stop: ran.append(1))
    gate.set()
    blocker.result(timeout=10)
    done = Future()
    submit(done, lambda: "after")
    assert done.result(timeout=10) == "after" and ran == []


def test_a_compiled_kernel_is_compiled_on_the_calling_thread(monkeypatch):
    """A first call compiles for many seconds: on the calling thread, where Ctrl-C stops
    the compiler at once, not on the worker thread, whose caller would wait for it all."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the test runner does not run tests on the main thread")

    @numba.njit(nogil=True)
    def kernel(values, scale, stop):
        return values.sum() * scale + stop[0]

    compiled_on = []
    compile_for = kernel.compile

    def spy(sig):
        compiled_on.append(threading.current_thread())
        return compile_for(sig)

    monkeypatch.setattr(kernel, "compile", spy)
    assert run_stoppable(True, kernel, np.arange(4.0), 2.0) == 12.0
    assert compiled_on == [threading.main_thread()]
    assert len(kernel.signatures) == 1  # the call found what the compilation made


def test_the_worker_keeps_no_reference_to_a_finished_calls_arguments():
    """Once a long call has returned, or raised, nothing of it stays alive on the worker:
    its arguments are freed with the caller's last reference (they were kept until the next
    call, a whole image's worth of memory while a command went on)."""
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("the test runner does not run tests on the main thread")
    for fails in (False, True):
        image = np.zeros(8)
        alive = weakref.ref(image)

        def call(a, stop, fails=fails):
            if fails:
                raise ValueError("bad")
            return float(a.sum())

        if fails:
            with pytest.raises(ValueError):
                run_stoppable(True, call, image)
        else:
            assert run_stoppable(True, call, image) == 0.0
        del image
        gc.collect()
        assert alive() is None, f"fails={fails}"
