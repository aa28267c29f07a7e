"""Atomic file output: write to temporary files in the same folder, then commit them as a unit.

Guarantees (tested in ``tests/faults`` and ``tests/core/test_atomic.py``):

* **Never a partial file.** Every output is written to a hidden temporary file next to it
  (``.NAME.PID-XXXXXXXX.part.EXT``) and only then given its final name.
* **Never an unasked-for overwrite, even under races.** Without ``force`` the final name is
  created with :func:`os.link` (fails if the name exists, atomically), so of two concurrent
  writers exactly one wins and the other gets :class:`~terrascape.errors.OutputExistsError`.
  A dangling symlink counts as existing.
* **One unit per command.** :func:`atomic_outputs` commits several files (a RAW file and its
  sidecar, a set of splat maps) together: all appear or none does. The commit holds an
  exclusive :func:`fcntl.flock` on each output folder, so two terrascape writers never
  interleave their renames, and a failure half-way rolls the already renamed files back
  (with ``force`` the previous files are restored from hard-link backups). Inside
  :func:`output_unit` (every export destination), every file written through these
  functions waits for the end of the block and is committed with the others: a command
  interrupted or failing half-way leaves none of its files, not the ones it had finished.
* **Durable once committed.** Each temporary file is flushed to the disk (:func:`os.fsync`)
  before it gets its final name, and each output folder after the renames, so after a power
  loss a committed name holds the new bytes (or, before the folder's sync, the old state),
  never an empty or half-written file.
* **Cleanup.** Temporary files are removed on any exception, including
  :class:`~terrascape.errors.Interrupted` (the CLI turns SIGINT, SIGTERM and SIGHUP into it).
  A temporary file left by a killed process (SIGKILL, power loss) carries its process id and
  is removed by the next write of the same output once that process no longer runs.
* **Clear errors.** An :class:`OSError` while writing becomes
  :class:`~terrascape.errors.OutputWriteError` (disk full, read-only, permission denied:
  exit code 1) or :class:`~terrascape.errors.FileFormatError` (a path that cannot exist:
  missing folder, a parent that is a file, a name too long: exit code 2), naming the path
  and the reason.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import os
import re
import signal
import tempfile
import threading
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from terrascape.errors import (
    FileFormatError,
    OutputExistsError,
    OutputWriteError,
    TerrascapeError,
)

try:  # POSIX only; on other systems the commit is still atomic per file, just not locked.
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

#: Errors caused by the path the user gave (exit 2); every other OSError is the machine's.
_USAGE_ERRNOS = {errno.ENOENT, errno.ENOTDIR, errno.ENAMETOOLONG, errno.EISDIR, errno.EINVAL,
                 errno.ELOOP}
#: The temporary name keeps at most this many characters of the final stem, so that a final
#: name near the file-system limit (255 bytes) still has a valid temporary name.
_STEM_CHARS = 80
_TEMP_RE = re.compile(r"^\.(?P<stem>.*)\.(?P<pid>\d+)-[A-Za-z0-9_]+\.(?:part|bak)(?P<ext>.*)$")


#: Outputs committed by this process since :func:`reset_committed` (the CLI's message on a
#: signal says which files a command had already finished).
_COMMITTED: list[Path] = []


#: Files committed in bulk (:func:`place_files`): ``(count, folder)``, not each path.
_COMMITTED_BULK: list[tuple[int, Path]] = []


def committed_outputs() -> list[Path]:
    """The files :func:`atomic_outputs` committed since the last :func:`reset_committed`."""
    return list(_COMMITTED)


def committed_in_bulk() -> list[tuple[int, Path]]:
    """How many files were committed in bulk since the last :func:`reset_committed`, and
    in which folder, per :func:`record_bulk_commit`."""
    return list(_COMMITTED_BULK)


def record_bulk_commit(count: int, folder: Path) -> None:
    """Count ``count`` files below ``folder`` as committed (their unit committed)."""
    _COMMITTED_BULK.append((count, Path(folder)))


def reset_committed() -> None:
    """Forget the committed outputs (the CLI calls this when a command starts)."""
    _COMMITTED.clear()
    _COMMITTED_BULK.clear()


def describe_os_error(
    exc: OSError, path: str | os.PathLike | None = None, *, verb: str = "cannot write"
) -> str:
    """``"cannot write PATH: REASON"`` with a hint for the common causes."""
    where = exc.filename if exc.filename is not None else path
    if where is None:
        where = "a file"
    reason = exc.strerror or str(exc)
    hint = {
        errno.ENOSPC: "; free some space or write to another disk",
        errno.EDQUOT: "; the disk quota is exhausted, free some space",
        errno.EROFS: "; the file system is read-only, write somewhere else",
        errno.EACCES: "; check the folder's permissions or write somewhere else",
        errno.EPERM: "; check the folder's permissions or write somewhere else",
        errno.ENAMETOOLONG: "; use a shorter file name",
        errno.ENOTDIR: "; a parent of this path is a file, not a folder",
    }.get(exc.errno or 0, "")
    if exc.errno is None:  # e.g. tifffile's "N requested and M written"
        hint = " (the write stopped short: the disk is probably full)"
    return f"{verb} {where}: {reason}{hint}"


def os_error_to_terrascape(exc: OSError, path: str | os.PathLike | None = None) -> TerrascapeError:
    """The typed error for an OSError on an output path (see the module docstring)."""
    if isinstance(exc, TerrascapeError):
        return exc
    message = describe_os_error(exc, path)
    if exc.errno in _USAGE_ERRNOS:
        return FileFormatError(message)
    return OutputWriteError(message, exc.errno)


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):
        return 255


def check_output_path(path: str | os.PathLike, *, force: bool = False) -> Path:
    """Refuse an output that cannot or must not be written, before any work is done.

    Raises :class:`OutputExistsError` if ``path`` exists (also a dangling symlink) and
    ``force`` is false; :class:`FileFormatError` for a directory, a missing folder, a parent
    that is a file or a name that is too long; :class:`OutputWriteError` if the folder is not
    writable (permissions or a read-only file system).
    """
    p = Path(path)
    try:
        return _check_output_path(p, force)
    except TerrascapeError:
        raise
    except OSError as exc:  # e.g. a path longer than PATH_MAX: stat() itself fails
        raise os_error_to_terrascape(exc, p) from None


def _check_output_path(p: Path, force: bool) -> Path:
    parent = p.parent
    limit = _name_max(parent) if parent.is_dir() else 255
    if len(os.fsencode(p.name)) > limit:
        raise FileFormatError(
            f"cannot write {p}: the file name is {len(os.fsencode(p.name))} bytes, this file "
            f"system allows {limit}; use a shorter name"
        )
    if p.is_dir():
        example = p / ("out" + (p.suffix or ".png"))
        raise FileFormatError(f"{p} is a folder; the output must be a file path, e.g. {example}")
    if os.path.lexists(p) and not force:
        what = "is a symlink (to a missing file)" if p.is_symlink() and not p.exists() else "exists"
        raise OutputExistsError(f"{p} {what}; pass --force (force=True) to overwrite it")
    if not parent.exists():
        # A parent that is a file makes exists() false for everything below it.
        for ancestor in p.parents:
            if ancestor.exists():
                if not ancestor.is_dir():
                    raise FileFormatError(
                        f"cannot write {p}: {ancestor} is a file, not a folder"
                    )
                break
        raise FileFormatError(f"output folder {parent} does not exist; create it first")
    if not parent.is_dir():
        raise FileFormatError(f"cannot write {p}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputWriteError(
            f"cannot write {p}: folder {parent} is not writable (permission denied or a "
            "read-only file system); write somewhere else",
            errno.EACCES,
        )
    return p


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _temp_prefix(final: Path) -> str:
    return f".{final.stem[:_STEM_CHARS]}.{os.getpid()}-"


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    except OSError:
        return True
    return True


def remove_stale_temporaries(final: str | os.PathLike) -> list[Path]:
    """Remove temporary files of ``final`` left by processes that no longer run.

    A SIGKILL or a power cut leaves ``.NAME.PID-XXXXXXXX.part.EXT`` behind; it is never read
    (hidden, never the final name) and is removed here, by the next write of the same output.
    Temporaries of running processes are left alone. Returns the removed paths.
    """
    final = Path(final)
    stem = final.stem[:_STEM_CHARS]
    removed = []
    try:
        entries = list(os.scandir(final.parent))
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP_RE.match(entry.name)
        if m is None or m["stem"] != stem or m["ext"] != final.suffix:
            continue
        if _pid_alive(int(m["pid"])):
            continue
        with contextlib.suppress(OSError):
            os.unlink(entry.path)
            removed.append(Path(entry.path))
    return removed


def _make_temp(final: Path, kind: str = "part") -> Path:
    fd, name = tempfile.mkstemp(
        prefix=_temp_prefix(final), suffix=f".{kind}{final.suffix}", dir=final.parent
    )
    os.close(fd)
    return Path(name)


#: Folders :func:`commit_lock` locks one by one; more are locked through their common folder.
_MAX_LOCKED_FOLDERS = 64


@contextlib.contextmanager
def commit_lock(folders: Sequence[str | os.PathLike], *, shared: bool = False) -> Iterator[None]:
    """Hold an :func:`fcntl.flock` on each folder (sorted, so two holders never deadlock).

    Writers commit under an exclusive lock, readers of a file pair (RAW + sidecar) read under
    a shared one, so a terrascape reader never sees half of a commit. Best effort: a folder
    that cannot be locked (no flock on this file system) is skipped.

    More than :data:`_MAX_LOCKED_FOLDERS` folders (a tile pyramid's ``z/x`` folders) are
    locked through their deepest common folder instead: one open file rather than one per
    folder, which the process's limit on open files (often 1,024) would not hold, and
    which the backups of a forced commit then could not be made beside. An export's unit
    holds its output folder either way (its ``layer.json``, its import note), so two
    exports into one folder still exclude each other.
    """
    fds = []
    unique = sorted({os.path.abspath(f) for f in folders})
    if len(unique) > _MAX_LOCKED_FOLDERS:
        unique = [os.path.commonpath(unique)]
    # a folder this thread holds already is not locked again: a second flock on another
    # open file of it would wait for this thread itself (a world export holds its folder
    # around its tiles and the commit of its metadata)
    held = _held_folders()
    mine = [folder for folder in unique if folder not in held]
    try:
        if fcntl is not None:
            for folder in mine:
                try:
                    fd = os.open(folder, os.O_RDONLY)
                except OSError:
                    continue
                fds.append(fd)
                held.add(folder)
                with contextlib.suppress(OSError):
                    fcntl.flock(fd, fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
        yield
    finally:
        held.difference_update(mine)
        for fd in fds:
            os.close(fd)  # closing releases the lock


_HELD = threading.local()


def _held_folders() -> set[str]:
    """The folders this thread holds a :func:`commit_lock` on."""
    if not hasattr(_HELD, "folders"):
        _HELD.folders = set()
    return _HELD.folders


def _link_new(tmp: Path, final: Path) -> None:
    """Give ``tmp`` the name ``final`` only if ``final`` does not exist (atomically)."""
    try:
        os.link(tmp, final)
    except FileExistsError:
        raise OutputExistsError(
            f"{final} was created by someone else while this command ran; nothing was "
            "overwritten (pass --force to overwrite it)"
        ) from None
    except OSError as exc:
        if exc.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK,
                             getattr(errno, "ENOTSUP", errno.EOPNOTSUPP)):
            raise
        # No hard links here (FAT, some network shares): reserve the name with O_EXCL, then
        # rename over the reservation. Still never replaces someone else's file.
        try:
            fd = os.open(final, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
        except FileExistsError:
            raise OutputExistsError(
                f"{final} was created by someone else while this command ran; nothing was "
                "overwritten (pass --force to overwrite it)"
            ) from None
        os.close(fd)
        os.replace(tmp, final)


_DEFERRED_SIGNALS = {getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                     if hasattr(signal, n)}


def _fsync_path(path: Path, *, folder: bool = False) -> None:
    """Flush ``path``'s data (a folder: its entries) to the disk.

    Without it a crash shortly after the rename can leave the new name pointing at a file
    whose blocks were never written (ext4's delayed allocation, XFS): a zero-length or
    garbage output although the command reported success.

    References
    ----------
    .. [1] T. Pillai et al., "All File Systems Are Not Created Equal: On the Complexity of
       Crafting Crash-Consistent Applications", OSDI 2014.
    """
    if folder:
        # After the renames the outputs are there and their bytes are synced: a folder that
        # cannot be opened or synced (EINVAL on some file systems) must not turn a finished
        # command into an error that reads "nothing was written".
        with contextlib.suppress(OSError):
            fd = os.open(path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def _signals_deferred() -> Iterator[None]:
    """Block SIGINT/SIGTERM/SIGHUP during a commit (a few renames): a signal then arrives
    after it, so a unit is never left half-renamed with its rollback cut short."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - Windows
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _DEFERRED_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _commit(pairs: list[tuple[Path, Path]], force: bool | Sequence[bool],
            find_removals: Callable[[], list[Path]] | None = None) -> list[Path]:
    """Rename every ``tmp`` to its ``final`` under the folder locks, then remove the files
    ``find_removals()`` names (asked under the locks); all or nothing (``force`` for all
    pairs, or one per pair). Returns the removed files."""
    done: list[tuple[Path, Path | None]] = []  # (final, backup of the old file or None)
    backups: list[Path] = []
    forced = [force] * len(pairs) if isinstance(force, bool) else list(force)
    removals: list[Path] = []
    with _signals_deferred(), commit_lock([final.parent for _tmp, final in pairs]):
        try:
            if find_removals is not None:
                removals = find_removals()
            for (tmp, final), force_one in zip(pairs, forced, strict=True):
                if force_one:
                    backup = None
                    if len(pairs) > 1 and os.path.lexists(final):
                        backup = _make_temp(final, "bak")
                        os.unlink(backup)
                        os.link(final, backup, follow_symlinks=False)
                        backups.append(backup)
                    os.replace(tmp, final)
                    done.append((final, backup))
                else:
                    _link_new(tmp, final)
                    done.append((final, None))
            for gone in removals:
                # kept as a backup until the commit is whole: a failure puts it back
                backup = _make_temp(gone, "bak")
                os.unlink(backup)
                os.replace(gone, backup)
                backups.append(backup)
                done.append((gone, backup))
        except BaseException:
            for final, backup in reversed(done):
                with contextlib.suppress(OSError):
                    if backup is not None:
                        os.replace(backup, final)
                    else:
                        os.unlink(final)
            raise
        finally:
            for backup in backups:
                with contextlib.suppress(OSError):
                    os.unlink(backup)
    return removals


def _fsync_folder(path: Path) -> None:
    _fsync_path(path, folder=True)


def _each(fn, items: list, threads: int) -> None:
    """``fn(item)`` for every item, on up to ``threads`` threads (errors re-raised)."""
    if threads <= 1 or len(items) <= 1:
        for item in items:
            fn(item)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(min(threads, len(items))) as pool:
        for _ in pool.map(fn, items):
            pass


@contextlib.contextmanager
def atomic_outputs(
    paths: Sequence[str | os.PathLike], *, force: bool = False, sync_threads: int = 1
) -> Iterator[list[Path]]:
    """Yield one temporary path per output; on success commit them all as one unit.

    Parameters
    ----------
    paths
        Final paths (distinct). They are committed in the given order under an exclusive
        lock of their folders; if any step fails, the files already committed are rolled
        back, so a reader sees either every new file or none.
    force
        Replace existing files; without it an existing file (also one created by another
        process while this one was writing) is never replaced.
    sync_threads
        Threads that flush the files (and folders) to the disk before (and after) the
        commit. A flush waits on the disk, not the CPU, and file systems serve concurrent
        flushes together (ext4 and XFS commit one journal transaction for them): a unit of
        thousands of small files (a tile pyramid) is flushed several times faster by a few
        threads than one after another.

    Raises
    ------
    OutputExistsError
        An output exists (before the work or at commit) and ``force`` is false.
    OutputWriteError, FileFormatError
        The file system refused a write (see :func:`os_error_to_terrascape`).
    """
    finals = [check_output_path(p, force=force) for p in paths]
    keys = [os.path.abspath(f) for f in finals]
    if len(set(keys)) != len(keys):
        raise FileFormatError(f"the outputs repeat a file name: {', '.join(map(str, finals))}")
    tmps: list[Path] = []
    try:
        try:
            for final in finals:
                remove_stale_temporaries(final)
                tmps.append(_make_temp(final))
        except OSError as exc:
            raise os_error_to_terrascape(exc, final) from None
        try:
            yield list(tmps)
        except OSError as exc:  # a writer's own OSError (disk full while writing, ...)
            where = next((f for t, f in zip(tmps, finals, strict=False)
                          if exc.filename in (str(t), t)), None)
            if where is not None and exc.filename is not None:
                exc.filename = str(where)
            raise os_error_to_terrascape(exc, where or finals[0]) from None
        for tmp, final in zip(tmps, finals, strict=True):
            if not tmp.exists() or tmp.stat().st_size == 0:
                raise FileFormatError(f"writing {final} produced no data")
        mode = 0o666 & ~_current_umask()
        try:
            for tmp in tmps:
                # mkstemp creates 0600 files; give the result the permissions open() would.
                os.chmod(tmp, mode)
            # The bytes are on the disk before the names point at them.
            _each(_fsync_path, tmps, sync_threads)
        except OSError as exc:
            raise os_error_to_terrascape(exc, finals[0]) from None
        unit = _UNIT.get()
        if unit is not None:
            # committed with the unit's other files at its end (or removed with them)
            unit.add(list(zip(tmps, finals, strict=True)), force)
            tmps = []
            return
        _commit_and_sync(list(zip(tmps, finals, strict=True)), force, sync_threads)
    finally:
        for tmp in tmps:
            with contextlib.suppress(OSError):
                tmp.unlink()


def _commit_and_sync(pairs: list[tuple[Path, Path]], force: bool | Sequence[bool],
                     sync_threads: int,
                     find_removals: Callable[[], list[Path]] | None = None) -> list[Path]:
    """:func:`_commit`, then the folders flushed so that the new names survive a power loss;
    an OSError becomes the typed error. Returns the removed files."""
    finals = [final for _tmp, final in pairs]
    try:
        removals = _commit(pairs, force, find_removals)
        _COMMITTED.extend(finals)
        folders = [path.parent for path in (*finals, *removals)]
        _each(_fsync_folder, list(dict.fromkeys(folders)), sync_threads)
    except TerrascapeError:
        raise
    except OSError as exc:
        raise os_error_to_terrascape(exc, finals[0]) from None
    return removals


class _Unit:
    """The files written inside one :func:`output_unit`, waiting for its commit, and the
    files it replaces by removing them."""

    def __init__(self) -> None:
        self.pairs: list[tuple[Path, Path]] = []
        self.forced: list[bool] = []
        self.keys: set[str] = set()
        self.finders: list[Callable[[], Sequence[Path]]] = []
        self.removed: list[Path] = []

    def removals(self) -> list[Path]:
        """The files the finders name that this unit does not write and that are files
        (asked at the commit, under its locks)."""
        found = []
        for find in self.finders:
            for path in map(Path, find()):
                if (os.path.abspath(path) not in self.keys and path.is_file()
                        and not path.is_symlink()):
                    found.append(path)
        return list(dict.fromkeys(found))

    def add(self, pairs: list[tuple[Path, Path]], force: bool) -> None:
        for tmp, final in pairs:
            key = os.path.abspath(final)
            if key in self.keys:  # its writer removes the temporary files it made
                raise FileFormatError(f"{final} was written twice by one command")
            self.keys.add(key)
            self.pairs.append((tmp, final))
            self.forced.append(force)


def flush_files(paths: Sequence[Path], *, threads: int = 1) -> None:
    """Flush the files ``paths`` to the disk, on up to ``threads`` threads."""
    _each(_fsync_path, list(paths), threads)


class PlacedFiles:
    """Files :func:`place_files` gave their final names: :meth:`undo` takes them back (and
    puts back the files they replaced) until the caller's unit has committed."""

    def __init__(self, pair_at: Callable[[int], tuple[str, str]], aside: Path) -> None:
        self._pair_at = pair_at
        self._aside = aside
        self.done = 0
        self.replaced = bytearray()  # 1 where an earlier file was moved aside

    def _place(self, count: int, force: bool) -> None:
        self.replaced = bytearray(count)
        for i in range(count):
            tmp, final = self._pair_at(i)
            if force:
                if os.path.lexists(final):
                    os.replace(final, self._aside / str(i))
                    self.replaced[i] = 1
                os.replace(tmp, final)
            else:
                _link_new(Path(tmp), Path(final))
            self.done = i + 1

    def undo(self) -> None:
        """Remove the placed files, newest first, and put back the ones they replaced."""
        with _signals_deferred():
            for i in reversed(range(self.done)):
                _tmp, final = self._pair_at(i)
                with contextlib.suppress(OSError):
                    os.unlink(final)
                    if self.replaced[i]:
                        os.replace(self._aside / str(i), final)
            self.done = 0


def place_files(count: int, pair_at: Callable[[int], tuple[str, str]], aside: Path, *,
                force: bool, sync_threads: int = 1) -> PlacedFiles:
    """Give ``count`` finished files their final names: ``pair_at(i)`` is the ``i``-th
    ``(tmp, final)`` (written and flushed to the disk, on the finals' file system; the
    finals' folders exist). All or none: a failure takes back the files placed so far; the
    files replaced (``force``) wait in the folder ``aside`` until the caller, once its own
    unit has committed, removes it, or until :meth:`PlacedFiles.undo`. Without ``force`` an
    existing final (another writer's) fails it. Made for the millions of tiles of a pyramid:
    each pair is made when it is needed, not held.

    Signals wait until the files are placed or taken back; the finals' folders are flushed
    to the disk afterwards on ``sync_threads`` threads."""
    placed = PlacedFiles(pair_at, Path(aside))
    try:
        with _signals_deferred():
            placed._place(count, force)
        folders = dict.fromkeys(os.path.dirname(pair_at(i)[1]) for i in range(count))
        _each(_fsync_folder, [Path(f) for f in folders], sync_threads)
    except BaseException as exc:
        where = pair_at(min(placed.done, count - 1))[1] if count else None
        placed.undo()
        if isinstance(exc, OSError) and not isinstance(exc, TerrascapeError):
            raise os_error_to_terrascape(exc, where) from None
        raise
    return placed


def in_output_unit() -> bool:
    """True inside an :func:`output_unit` (whose commit is at the outermost one's end)."""
    return _UNIT.get() is not None


def unit_outputs() -> list[Path]:
    """The final paths of the files written so far in the current :func:`output_unit`
    (empty outside one)."""
    unit = _UNIT.get()
    return [] if unit is None else [final for _tmp, final in unit.pairs]


def remove_with_unit(find: Callable[[], Sequence[str | os.PathLike]]) -> list[Path]:
    """Remove the files ``find()`` names (files this unit's writer made before and no
    longer writes) when the current :func:`output_unit` commits, under the same
    all-or-nothing: if the commit fails, they stay. ``find`` is called at the commit,
    under the folders' locks, so that a writer that committed meanwhile is seen. A path
    the unit writes, or that is not a file, is left alone. Returns the list the removed
    files are put in once the unit has committed."""
    unit = _UNIT.get()
    if unit is None:
        raise RuntimeError("remove_with_unit needs an output_unit")
    unit.finders.append(find)
    return unit.removed


_UNIT: contextvars.ContextVar[_Unit | None] = contextvars.ContextVar("terrascape_output_unit",
                                                                    default=None)


@contextlib.contextmanager
def output_unit(*, sync_threads: int = 1) -> Iterator[None]:
    """Commit every file written inside the block (through :func:`atomic_output` and
    :func:`atomic_outputs`) together, when the block ends without an error.

    Each file is still written to its temporary file, checked and flushed to the disk as
    it is finished; its final name waits for the block's end. Then all are renamed under
    the folders' locks, all or none (as one :func:`atomic_outputs`), each with its own
    ``force``. If the block raises (a signal, a full disk, a refused overwrite), every
    temporary file is removed and no final name appears, not even those of the files
    finished first. A block inside another one joins the outer unit.

    Parameters
    ----------
    sync_threads
        Threads that flush the output folders after the commit.
    """
    if _UNIT.get() is not None:
        yield
        return
    unit = _Unit()
    token = _UNIT.set(unit)
    try:
        try:
            yield
        finally:
            _UNIT.reset(token)
        if unit.pairs:
            unit.removed.extend(_commit_and_sync(unit.pairs, unit.forced, sync_threads,
                                                 unit.removals if unit.finders else None))
    finally:
        for tmp, _final in unit.pairs:
            with contextlib.suppress(OSError):
                tmp.unlink()


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, *, force: bool = False) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success give it the name ``path``.

    The temporary name keeps the final suffix, so writers that pick a format by extension
    (Pillow, tifffile) behave the same. See :func:`atomic_outputs` for the guarantees.
    """
    with atomic_outputs([path], force=force) as (tmp,):
        yield tmp
