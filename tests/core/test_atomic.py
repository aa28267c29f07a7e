import pytest

from terrascape.errors import FileFormatError, OutputExistsError
from terrascape.io.atomic import atomic_output


def test_success_renames_and_leaves_no_temp(tmp_path):
    target = tmp_path / "out.txt"
    with atomic_output(target) as tmp:
        assert tmp.suffix == ".txt" and tmp.parent == tmp_path
        tmp.write_text("hello")
        assert not target.exists()
    assert target.read_text() == "hello"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_failure_keeps_existing_file_and_removes_temp(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_output(target, force=True) as tmp:
        tmp.write_text("half")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.txt"]


def test_refuses_overwrite_without_force(tmp_path):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(OutputExistsError, match="--force"), atomic_output(target):
        pass


def test_missing_folder_and_empty_output(tmp_path):
    with pytest.raises(FileFormatError), atomic_output(tmp_path / "nope" / "x.bin"):
        pass
    with pytest.raises(FileFormatError, match="no data"), atomic_output(tmp_path / "e.bin"):
        pass
    assert list(tmp_path.iterdir()) == []


def test_output_gets_umask_permissions(tmp_path):
    import os

    mask = os.umask(0o022)
    try:
        with atomic_output(tmp_path / "p.txt") as tmp:
            tmp.write_text("x")
    finally:
        os.umask(mask)
    assert (tmp_path / "p.txt").stat().st_mode & 0o777 == 0o644


# --- races, symlinks, groups, stale temporaries --------------------------------------------
import errno  # noqa: E402
import os  # noqa: E402

from terrascape.errors import OutputWriteError  # noqa: E402
from terrascape.io.atomic import (  # noqa: E402
    atomic_outputs,
    check_output_path,
    remove_stale_temporaries,
)


def test_race_loser_gets_clear_error(tmp_path):
    target = tmp_path / "o.bin"
    outer = atomic_output(target)
    tmp_a = outer.__enter__()
    tmp_a.write_bytes(b"A")
    with atomic_output(target) as tmp_b:
        tmp_b.write_bytes(b"B")
    with pytest.raises(OutputExistsError, match="created by someone else"):
        outer.__exit__(None, None, None)
    assert target.read_bytes() == b"B"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.bin"]


def test_dangling_symlink_needs_force(tmp_path):
    link = tmp_path / "o.png"
    link.symlink_to(tmp_path / "missing.png")
    with pytest.raises(OutputExistsError, match="symlink"):
        check_output_path(link)
    with atomic_output(link, force=True) as tmp:
        tmp.write_bytes(b"new")
    assert not link.is_symlink() and link.read_bytes() == b"new"
    assert not (tmp_path / "missing.png").exists()


def test_directory_parent_file_and_long_name_messages(tmp_path):
    (tmp_path / "adir").mkdir()
    with pytest.raises(FileFormatError, match="is a folder; the output must be a file path"):
        check_output_path(tmp_path / "adir")
    (tmp_path / "f").write_text("x")
    with pytest.raises(FileFormatError, match="is a file, not a folder"):
        check_output_path(tmp_path / "f" / "o.png")
    with pytest.raises(FileFormatError, match="use a shorter name"):
        check_output_path(tmp_path / ("x" * 300 + ".png"))
    # A name near the limit still gets a valid temporary name.
    near = tmp_path / ("y" * 250 + ".png")
    with atomic_output(near) as tmp:
        tmp.write_bytes(b"ok")
    assert near.read_bytes() == b"ok"


def test_group_commit_is_all_or_nothing(tmp_path, monkeypatch):
    a, b = tmp_path / "a.bin", tmp_path / "b.bin"
    a.write_bytes(b"old a")
    b.write_bytes(b"old b")
    real_replace = os.replace
    calls = []

    def failing_replace(src, dst, *args, **kwargs):
        calls.append(dst)
        if str(dst) == str(b):  # the second rename: the disk "fills up"
            raise OSError(errno.ENOSPC, "No space left on device", str(dst))
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", failing_replace)
    with pytest.raises(OutputWriteError, match="No space left on device"), atomic_outputs(
        [a, b], force=True
    ) as (ta, tb):
        ta.write_bytes(b"new a")
        tb.write_bytes(b"new b")
    monkeypatch.setattr(os, "replace", real_replace)
    assert a.read_bytes() == b"old a" and b.read_bytes() == b"old b"  # a was rolled back
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bin", "b.bin"]


def test_group_commit_without_force_removes_its_first_file_on_failure(tmp_path):
    a, b = tmp_path / "a.bin", tmp_path / "b.bin"
    with pytest.raises(OutputExistsError), atomic_outputs([a, b]) as (ta, tb):
        ta.write_bytes(b"a")
        tb.write_bytes(b"b")
        b.write_bytes(b"someone else")  # b appears while we write
    assert not a.exists() and b.read_bytes() == b"someone else"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.bin"]


def test_stale_temporary_of_dead_process_is_removed(tmp_path):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead = int(proc.stdout)
    stale = tmp_path / f".o.{dead}-abcd1234.part.png"
    stale.write_bytes(b"half")
    alive = tmp_path / f".o.{os.getpid()}-zzzz9999.part.png"  # ours: still running
    alive.write_bytes(b"mine")
    other = tmp_path / f".p.{dead}-abcd1234.part.png"  # another output's: not touched
    other.write_bytes(b"x")
    assert remove_stale_temporaries(tmp_path / "o.png") == [stale]
    with atomic_output(tmp_path / "o.png") as tmp:
        tmp.write_bytes(b"new")
    assert not stale.exists() and alive.exists() and other.exists()


def test_writer_oserror_becomes_typed_error_naming_the_output(tmp_path):
    target = tmp_path / "o.bin"
    with pytest.raises(OutputWriteError, match=r"cannot write .*o\.bin: No space left"), \
            atomic_output(target) as tmp:
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
    assert list(tmp_path.iterdir()) == []


# a unit of one small file in each of N folders, forced over the same files, in a process
# allowed 200 open files
_MANY_FOLDERS = """
import resource, sys
from pathlib import Path
from terrascape.io.atomic import atomic_output, output_unit
root, n = Path(sys.argv[1]), int(sys.argv[2])
resource.setrlimit(resource.RLIMIT_NOFILE, (200, resource.getrlimit(resource.RLIMIT_NOFILE)[1]))
for run in range(2):
    with output_unit():
        for i in range(n):
            (root / str(i)).mkdir(exist_ok=True)
            with atomic_output(root / str(i) / "t.bin", force=run == 1) as tmp:
                Path(tmp).write_bytes(bytes([run]) * 10)
print(sorted({p.read_bytes() for p in root.rglob("t.bin")}))
"""


def test_a_forced_unit_over_more_folders_than_open_files_commits(tmp_path):
    """A tile pyramid's unit spans thousands of ``z/x`` folders. Locked one open file per
    folder, they took every file the process may open (often 1,024), and the forced
    commit's backups then failed ("Too many open files"); they are locked through their
    common folder instead."""
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", _MANY_FOLDERS, str(tmp_path), "500"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == repr([bytes([1]) * 10])
    assert not [p for p in tmp_path.rglob("*") if p.name.startswith(".")]  # no temporary


def test_commit_lock_takes_the_common_folder_of_many(tmp_path, monkeypatch):
    from terrascape.io import atomic

    opened = []
    real_open = os.open
    monkeypatch.setattr(os, "open", lambda path, *a, **k: opened.append(path) or
                        real_open(path, *a, **k))
    few = [tmp_path / "a", tmp_path / "b" / "c"]
    many = [tmp_path / str(i) / str(j) for i in range(3) for j in range(30)]
    for folder in few + many:
        folder.mkdir(parents=True, exist_ok=True)
    with atomic.commit_lock(few):
        pass
    assert sorted(opened) == sorted(str(f) for f in few)
    opened.clear()
    with atomic.commit_lock(many):
        pass
    assert opened == [str(tmp_path)]


def test_a_unit_removes_what_its_finder_names_at_the_commit(tmp_path):
    """The files to remove are asked for at the commit, under the folders' lock (a writer
    that committed meanwhile is seen), never a file the unit writes, and kept when the
    commit fails."""
    from pathlib import Path

    from terrascape.io.atomic import output_unit, remove_with_unit

    old, late, mine = tmp_path / "old.txt", tmp_path / "late.txt", tmp_path / "new.txt"
    old.write_text("old")
    (tmp_path / "sub").mkdir()
    with output_unit():
        removed = remove_with_unit(lambda: [old, late, mine, tmp_path / "sub"])
        with atomic_output(mine) as tmp:
            Path(tmp).write_text("new")
        late.write_text("committed by another writer meanwhile")
        assert old.exists() and removed == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.txt", "sub"]
    assert removed == [old, late] and mine.read_text() == "new"

    old.write_text("old")
    with pytest.raises(OutputExistsError), output_unit():
        remove_with_unit(lambda: [old])
        with atomic_output(tmp_path / "x.txt") as tmp:
            Path(tmp).write_text("x")
        (tmp_path / "x.txt").write_text("someone else's")  # the commit fails on it
    assert old.read_text() == "old" and (tmp_path / "x.txt").read_text() == "someone else's"


def test_a_folder_lock_is_reentrant_in_its_thread_and_excludes_other_threads(tmp_path):
    """A command that holds its output folder's lock around a long commit (a world's
    tiles, then their metadata) takes it again for the inner commit without waiting on
    itself; another thread still waits until it is released."""
    import threading
    import time

    from terrascape.io.atomic import commit_lock

    entered = []

    def other():
        with commit_lock([tmp_path]):
            entered.append(time.monotonic())

    with commit_lock([tmp_path]):
        with commit_lock([tmp_path]):  # the same thread: no deadlock
            pass
        thread = threading.Thread(target=other)
        thread.start()
        time.sleep(0.3)
        assert entered == []  # still held after the inner block
        released = time.monotonic()
    thread.join(10)
    assert entered and entered[0] >= released
