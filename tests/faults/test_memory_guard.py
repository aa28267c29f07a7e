"""Peak-memory estimates refuse impossible requests before allocating (exit 1, one line, no
file); ``--max-memory`` moves the limit."""

from __future__ import annotations

import re

import numpy as np
import pytest

from terrascape import Heightmap
from terrascape.cli.app import run_app
from terrascape.errors import MemoryLimitError
from terrascape.io import write_heightmap
from terrascape.memory import check_memory, estimate_peak, memory_limit, set_limit

# stage timings ("read… 0.00 s") and the note a stage still running after 5 s prints (a
# first run compiling, or a loaded machine): not error lines
_NOT_ERRORS = r"… \d+\.\d+ s$|: still working after \d"


def _one_error_line(err: str) -> str:
    """The one error line (timing lines like ``read… 0.00 s`` aside)."""
    lines = [line for line in err.splitlines()
             if line.strip() and not re.search(_NOT_ERRORS, line)]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


def test_limit_sources(monkeypatch):
    monkeypatch.setattr("terrascape.memory.available_bytes", lambda: 10 * 1024**3)
    monkeypatch.delenv("TERRASCAPE_MAX_MEMORY", raising=False)
    set_limit(None)
    assert memory_limit() == 8 * 1024**3  # 80 % of available
    monkeypatch.setenv("TERRASCAPE_MAX_MEMORY", "1G")
    assert memory_limit() == 1024**3
    set_limit("25%")
    try:
        assert memory_limit() == int(2.5 * 1024**3)
    finally:
        set_limit(None)


def test_refusal_names_estimate_limit_and_available(monkeypatch):
    monkeypatch.setattr("terrascape.memory.available_bytes", lambda: 2 * 1024**3)
    monkeypatch.delenv("TERRASCAPE_MAX_MEMORY", raising=False)
    set_limit(None)
    with pytest.raises(MemoryLimitError, match=r"about 3 GiB .* limit of 1\.6 GiB .* 2 GiB "
                                               r"available now\); use less"):
        check_memory(3 * 1024**3, "thing", hint="use less")
    check_memory(1024**3, "thing")  # under the limit: nothing happens
    # just over the limit: enough digits that the two figures differ
    set_limit("1G")
    try:
        with pytest.raises(MemoryLimitError, match=r"about 1\.0002 GiB .* limit of 1 GiB "):
            check_memory(1.0002 * 1024**3, "thing")
    finally:
        set_limit(None)


@pytest.mark.parametrize("argv", [
    ["generate", "diamond-square", "--size", "65537"],
    ["generate", "fault", "--size", "40000"],
    ["generate", "fbm", "--size", "30000x30000"],
])
def test_generators_refuse_before_allocating(tmp_path, capsys, argv):
    out = tmp_path / "big.png"
    code = run_app([*argv, "-o", str(out), "--max-memory", "8G"])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1
    assert "memory at its peak (estimate)" in line and "limit of 8 GiB" in line
    assert "--size" in line
    assert list(tmp_path.iterdir()) == []


def test_render_generate_refuses(tmp_path, capsys):
    code = run_app(["render", "--generate", "diamond-square", "--gen-size", "65537",
                    "-o", str(tmp_path / "r.png"), "--max-memory", "8G"])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and "--gen-size" in line
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def small_map(tmp_path):
    path = tmp_path / "in.npy"
    write_heightmap(Heightmap(np.random.default_rng(1).random((33, 33)).astype(np.float32)),
                    path)
    return path


@pytest.mark.parametrize("argv", [
    ["blur", "{in}", "{out}.npy", "--sigma", "1e9"],
    ["heightfromimage", "{img}", "-o", "{out}.png", "--blur", "1e9"],
    ["heightfromimage", "{img}", "-o", "{out}.png", "--highpass", "1e9"],
])
def test_huge_kernels_are_refused_not_a_memory_error(tmp_path, small_map, capsys, argv):
    from PIL import Image

    img = tmp_path / "photo.png"
    pixels = (np.random.default_rng(2).random((20, 20, 3)) * 255).astype(np.uint8)
    Image.fromarray(pixels).save(img)
    args = [a.format(**{"in": small_map, "out": tmp_path / "o", "img": img}) for a in argv]
    code = run_app(args)
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and "estimate" in line and "smaller" in line
    assert not any(p.name.startswith("o") for p in tmp_path.iterdir())


def test_max_memory_lets_small_jobs_through(tmp_path, capsys):
    out = tmp_path / "ok.npy"
    assert run_app(["generate", "diamond-square", "--size", "65", "-o", str(out), "-q",
                    "--max-memory", "1G"]) == 0
    assert np.load(out).shape == (65, 65)
    est = estimate_peak("diamond-square", 65, 65)
    assert est < 1024**2


def test_bad_max_memory_is_usage_error(tmp_path, capsys):
    code = run_app(["generate", "diamond-square", "--size", "65", "-o", str(tmp_path / "x.npy"),
                    "--max-memory", "lots"])
    assert code == 2 and "--max-memory must look like" in capsys.readouterr().err


def test_a_memory_error_that_still_happens_is_one_line(tmp_path, capsys, monkeypatch):
    import terrascape.cli.cmd_generate

    def exhausted(*_args, **_kwargs):
        raise MemoryError

    monkeypatch.setattr(terrascape.cli.cmd_generate, "generate", exhausted)
    code = run_app(["generate", "diamond-square", "--size", "65", "-o", str(tmp_path / "x.png")])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and line.startswith("error: out of memory") and "nothing was written" in line
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def rough_map(tmp_path):
    """129² of noise: at error 0 every sample is a vertex (2·128² = 32,768 triangles)."""
    path = tmp_path / "rough.npy"
    heights = np.random.default_rng(3).random((129, 129)).astype(np.float32) * 50
    write_heightmap(Heightmap(heights), path)
    return path


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".glb"])
@pytest.mark.parametrize("mesher", ["rtin", "greedy"])
def test_mesh_too_big_to_write_is_refused_once_its_size_is_known(tmp_path, rough_map, capsys,
                                                                  suffix, mesher):
    """The same map and limit: the full-grid mesh is refused (its triangles × the format's
    bytes per triangle exceed the limit), a coarse one is written."""
    from terrascape.memory import PEAK_BYTES_PER_TRIANGLE

    limit = 4 * 1024**2
    assert 32_768 * PEAK_BYTES_PER_TRIANGLE[suffix] > limit  # the premise of the refusal
    out = tmp_path / f"mesh{suffix}"
    before = sorted(tmp_path.iterdir())
    code = run_app(["mesh", str(rough_map), "-o", str(out), "--max-error", "0", "--mesher",
                    mesher, "--max-memory", str(limit)])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1
    assert "a mesh of 32,768 triangles" in line and "--max-error" in line
    assert "estimate" in line and "limit of 4 MiB" in line
    assert sorted(tmp_path.iterdir()) == before
    code = run_app(["mesh", str(rough_map), "-o", str(out), "--max-error", "1000", "--mesher",
                    mesher, "--max-memory", str(limit), "-q"])
    assert code == 0 and out.stat().st_size > 0


def test_mesh_triangle_budget_is_checked_before_meshing(tmp_path, rough_map, capsys,
                                                        monkeypatch):
    from terrascape.lod import static_meshers

    def never(*_args, **_kwargs):
        raise AssertionError("meshed although the budget alone is over the limit")

    monkeypatch.setattr(static_meshers.StaticMesher, "mesh", never)
    before = sorted(tmp_path.iterdir())
    code = run_app(["mesh", str(rough_map), "-o", str(tmp_path / "m.ply"), "--triangles",
                    "100000000", "--max-memory", "1G"])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and "up to 100,000,000 triangles" in line and "limit of 1 GiB" in line
    assert sorted(tmp_path.iterdir()) == before


@pytest.mark.parametrize("argv", [["web"], ["blender", "--format", "glb"]])
def test_export_mesh_too_big_is_refused_once_built(tmp_path, rough_map, capsys, argv):
    """The exports that mesh the whole map: the full-grid mesh refused before anything is
    written (no output folder left), the same map's coarse mesh exported under the same
    limit."""
    out = tmp_path / "out"
    code = run_app(["export", argv[0], str(rough_map), "-o", str(out), *argv[1:],
                    "--max-error", "0", "--max-memory", "4M"])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1
    assert "a mesh of 32,768 triangles" in line and "--max-error" in line
    assert "limit of 4 MiB" in line and "nothing was written" in line
    assert not out.exists()
    code = run_app(["export", argv[0], str(rough_map), "-o", str(out), *argv[1:],
                    "--max-error", "1000", "--max-memory", "4M", "-q"])
    assert code == 0 and any(p.suffix == ".glb" for p in out.iterdir())


def test_greedy_tin_refuses_a_join_that_cannot_fit():
    """Meshed in pieces, the greedy TIN knows its size before it joins them: a join over the
    limit is refused there (the API raises), a coarse mesh of the same map is joined."""
    from terrascape.lod.greedy_tin import greedy_tin
    from terrascape.memory import PEAK_BYTES_PER_TRIANGLE

    hm = Heightmap(np.random.default_rng(4).random((400, 400)).astype(np.float32) * 50)
    full = 2 * 399 * 399  # every sample a vertex: 2 × 2 pieces, joined
    set_limit("10M")
    try:
        assert full * PEAK_BYTES_PER_TRIANGLE["greedy join"] > 10 * 1024**2
        with pytest.raises(MemoryLimitError, match=f"greedy TIN of {full:,} triangles"):
            greedy_tin(hm, max_error=0.0)
        assert len(greedy_tin(hm, max_error=1000.0)) < 100
    finally:
        set_limit(None)


@pytest.mark.parametrize("threads", [1, 2])
def test_greedy_tin_stops_meshing_pieces_once_the_join_cannot_fit(monkeypatch, threads):
    """A big map's pieces are not all meshed before the refusal: once the pieces so far are
    over the limit, those not started are dropped (36 pieces here, refused after 13 of
    them), and the message says the mesh has at least that many triangles."""
    import time

    import terrascape.lod.greedy_tin as gt
    from terrascape.memory import PEAK_BYTES_PER_TRIANGLE

    meshed = []
    mesh_piece = gt._mesh_piece

    def counted(*args):
        meshed.append(args[3:5])
        if threads > 1:
            # a piece this small takes about a millisecond: slowed down, the pieces cannot
            # all be done before the main thread has read the first ones' sizes
            time.sleep(0.05)
        return mesh_piece(*args)

    monkeypatch.setattr(gt, "_PIECE", 64)
    monkeypatch.setattr(gt, "_mesh_piece", counted)
    monkeypatch.setattr(gt.numba, "get_num_threads", lambda: threads)
    hm = Heightmap(np.random.default_rng(5).random((400, 400)).astype(np.float32) * 50)
    set_limit("10M")
    try:
        with pytest.raises(MemoryLimitError, match="greedy TIN of at least") as refused:
            gt.greedy_tin(hm, max_error=0.0)
    finally:
        set_limit(None)
    if threads > 1:
        # whatever the pool still had queued has started once a job queued after it runs
        gt._thread_pool(threads).submit(lambda: None).result()
    at_least = int(re.search(r"at least ([\d,]+)", str(refused.value))[1].replace(",", ""))
    assert at_least * PEAK_BYTES_PER_TRIANGLE["greedy join"] > 10 * 1024**2
    assert (len(gt._piece_edges(400)) - 1) ** 2 == 36
    # each piece about 8,000 triangles (0.8 MB by the join's model): 13 are over 10 MiB
    if threads == 1:
        assert len(meshed) == 13
    else:  # the pieces another thread had started meanwhile are meshed too
        assert 13 <= len(meshed) < 36


def test_greedy_tin_in_one_order_stops_before_its_arrays_pass_the_limit(tmp_path, capsys):
    """One greedy order (``--one-piece``, or the API's ``in_pieces=False``) grows its arrays
    as it inserts: it stops before a doubling would pass the limit, with one line and no
    file; the same map's coarse mesh is written under the same limit."""
    from terrascape.lod.greedy_tin import greedy_tin
    from terrascape.memory import PEAK_BYTES_PER_TRIANGLE

    heights = np.random.default_rng(6).random((400, 400)).astype(np.float32) * 50
    hm = Heightmap(heights)
    per_slot = PEAK_BYTES_PER_TRIANGLE["greedy one order"]
    limit = 10 * 1024**2
    # 2·399² triangles at error 0; the arrays stop at 65,536 slots: the next doubling's
    # 131,072 slots pass the limit
    assert 65_536 * per_slot <= limit < 131_072 * per_slot < 2 * 399**2 * per_slot
    set_limit(limit)
    try:
        with pytest.raises(MemoryLimitError, match=r"greedy TIN in one order of more than "
                                                   r"65,536 triangles needs about 10\.6 MiB"):
            greedy_tin(hm, max_error=0.0, in_pieces=False)
        assert len(greedy_tin(hm, max_error=1000.0, in_pieces=False)) < 100
    finally:
        set_limit(None)

    path = tmp_path / "rough.npy"
    write_heightmap(hm, path)
    out = tmp_path / "mesh.ply"
    code = run_app(["mesh", str(path), "-o", str(out), "--mesher", "greedy", "--one-piece",
                    "--max-error", "0", "--max-memory", "10M"])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and not out.exists()
    assert "more than 65,536 triangles" in line and "limit of 10 MiB" in line
    assert "nothing was written" in line
    code = run_app(["mesh", str(path), "-o", str(out), "--mesher", "greedy", "--one-piece",
                    "--max-error", "40", "--max-memory", "10M", "-q"])
    assert code == 0 and out.exists()


def test_shade_estimates_the_daylight_models_own_peak(tmp_path, small_map, capsys):
    """The daylight model (shade's default) peaks at up to 45 B a sample (RGB at 2049²),
    the classic one at up to 14 B: a limit between the two estimates refuses the first
    with one line and no file, and lets the second through."""
    from terrascape.memory import PEAK_BYTES_PER_SAMPLE

    assert PEAK_BYTES_PER_SAMPLE["shade daylight"] >= 45.0
    daylight = estimate_peak("shade daylight", 2049, 2049)
    classic = estimate_peak("shade", 2049, 2049)
    assert daylight > 2 * classic
    big = tmp_path / "big.npy"
    np.save(big, np.zeros((2049, 2049), np.float32))
    limit = str(int((daylight + classic) / 2))
    code = run_app(["shade", str(big), "-o", str(tmp_path / "d.png"), "--max-memory", limit])
    line = _one_error_line(capsys.readouterr().err)
    assert code == 1 and "--lighting classic" in line
    assert not (tmp_path / "d.png").exists()
    assert run_app(["shade", str(big), "-o", str(tmp_path / "c.png"), "--max-memory", limit,
                    "--lighting", "classic", "-q"]) == 0
    assert (tmp_path / "c.png").exists()
