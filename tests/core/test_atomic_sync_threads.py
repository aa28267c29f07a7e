"""A unit of many files flushed by several threads: the same guarantees as one by one."""

from __future__ import annotations

from pathlib import Path

import pytest

from terrascape.errors import OutputExistsError
from terrascape.export._common import write_many
from terrascape.io.atomic import atomic_outputs


def test_threaded_unit_writes_every_file_and_leaves_no_temporaries(tmp_path):
    paths = [tmp_path / str(k % 5) / f"{k}.bin" for k in range(60)]
    for p in paths:
        p.parent.mkdir(exist_ok=True)
    with atomic_outputs(paths, sync_threads=4) as tmps:
        for k, t in enumerate(tmps):
            Path(t).write_bytes(bytes([k]) * (k + 1))
    assert all(p.read_bytes() == bytes([k]) * (k + 1) for k, p in enumerate(paths))
    assert sorted(q.name for q in tmp_path.rglob("*") if q.is_file()) == \
        sorted(p.name for p in paths)


def test_write_many_is_all_or_nothing(tmp_path):
    items = [(tmp_path / "a" / f"{k}.terrain", b"x" * (k + 1)) for k in range(20)]
    items[7][0].parent.mkdir()
    items[7][0].write_bytes(b"old")
    with pytest.raises(OutputExistsError):
        write_many(items, force=False)
    assert [p.name for p in (tmp_path / "a").iterdir()] == ["7.terrain"]
    assert items[7][0].read_bytes() == b"old"
    written = write_many(items, force=True)
    assert written == [p for p, _ in items]
    assert all(p.read_bytes() == data for p, data in items)
    assert write_many([], force=False) == []
