"""Two processes writing the same output at once. Without --force exactly one wins and the
other gets a clear error; with --force both succeed and the final RAW + sidecar pair is one
run's complete pair (byte-compared with reference files), never a mix."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import pytest

from terrascape.generate.registry import generate
from terrascape.io import write_heightmap

SRC = str(pathlib.Path(__file__).resolve().parents[2] / "src")
ENV = {**os.environ, "PYTHONPATH": SRC}
SIZE = 257


@pytest.fixture(scope="module")
def references(tmp_path_factory):
    """The bytes each seed's run must leave: ``{seed: (raw, sidecar)}``."""
    folder = tmp_path_factory.mktemp("ref")
    refs = {}
    for seed in (1, 2):
        path = folder / f"s{seed}.r16"
        # what `terrascape generate diamond-square --seed S` makes (the registry's terrain)
        write_heightmap(generate("diamond-square", SIZE, seed=seed), path)
        refs[seed] = (path.read_bytes(), (folder / f"s{seed}.r16.json").read_bytes())
    return refs


def _race(out, force: bool):
    extra = ["--force"] if force else []
    procs = {
        seed: subprocess.Popen(
            [sys.executable, "-c", "from terrascape.cli import main; main()", "generate",
             "diamond-square", "--size", str(SIZE), "--seed", str(seed), "-o", str(out), "-q",
             *extra],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
        )
        for seed in (1, 2)
    }
    done = {seed: p.communicate(timeout=120)[1] for seed, p in procs.items()}
    return {seed: (procs[seed].returncode, err) for seed, err in done.items()}


def test_without_force_exactly_one_writer_wins(tmp_path, references):
    out = tmp_path / "o.r16"
    results = _race(out, force=False)
    codes = sorted(code for code, _err in results.values())
    assert codes == [0, 2], results
    winner = next(seed for seed, (code, _e) in results.items() if code == 0)
    loser_err = next(err for code, err in results.values() if code == 2)
    assert "Traceback" not in loser_err
    assert "o.r16" in loser_err and ("exists" in loser_err or "someone else" in loser_err)
    assert "--force" in loser_err
    # On disk: the winner's complete pair, byte for byte, and nothing else.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.r16", "o.r16.json"]
    assert (out.read_bytes(), (tmp_path / "o.r16.json").read_bytes()) == references[winner]


@pytest.mark.parametrize("round_", range(2))
def test_with_force_the_final_pair_is_one_runs_pair(tmp_path, references, round_):
    out = tmp_path / "o.r16"
    results = _race(out, force=True)
    assert all(code == 0 for code, _err in results.values()), results
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.r16", "o.r16.json"]
    pair = (out.read_bytes(), (tmp_path / "o.r16.json").read_bytes())
    assert pair in (references[1], references[2])
