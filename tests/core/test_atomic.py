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
