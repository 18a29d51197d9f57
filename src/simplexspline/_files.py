"""Writing files safely and as open JSON: atomic writes, JSON conversion of numpy values.

Every file the project writes goes through :func:`atomic_write`: a temporary file next to
the target, flushed, then renamed over it, so a reader sees the old file or the new one,
never half of one. :func:`jsonable` turns numpy scalars and arrays (and tuples, sets, NaN)
into plain JSON values.

A writer holds an advisory lock (``flock``, where the platform has it) on each of its
temporary files and directories for as long as it works on them: :func:`remove_stale`
removes at once a temporary whose writer is gone (killed), and keeps a live writer's.
:func:`locked` serialises writers of one directory (two ``identify -o DIR`` at once).
"""

from __future__ import annotations

import contextlib
import math
import os
import secrets
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping
from glob import escape as glob_escape
from pathlib import Path

import numpy as np

try:
    import fcntl
except ImportError:  # not POSIX: no locks; stale temporaries go by age alone
    fcntl = None

__all__ = ["STALE_AFTER_S", "atomic_write", "jsonable", "locked", "remove_stale",
           "temp_dir", "write_bytes", "write_text", "write_together"]


def _umask() -> int:
    """The process's file-mode creation mask: read from /proc where it is shown (Linux), so
    that other threads never see it changed; elsewhere set and restored at once."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _as_if_created(tmp: str | os.PathLike) -> None:
    """Give a temporary file the mode a plain ``open(path, 'w')`` would (0666 & ~umask):
    :func:`tempfile.mkstemp` creates 0600, which the rename would carry to the target."""
    os.chmod(tmp, 0o666 & ~_umask())


#: Temporary files and directories older than this [s] are removed by the next write to the
#: same place even when their writer cannot be asked (no ``flock`` on the platform).
STALE_AFTER_S = 3600.0


def _open_for_lock(path: str | os.PathLike) -> int:
    """A read-only descriptor of a file or directory, to hold a lock on."""
    return os.open(path, os.O_RDONLY)


def _hold(make: Callable[[], tuple[int | None, str]]) -> tuple[int | None, str]:
    """Make a temporary (``make() -> (descriptor or None, path)``) and lock it for its
    writer. Should a cleaner have removed it between its creation and the lock, a new
    one is made: the path held is always the one locked."""
    while True:
        fd, path = make()
        if fcntl is None:         # nothing to hold (and an open file could not be renamed)
            if fd is not None:
                os.close(fd)
            return None, path
        try:
            if fd is None:
                fd = _open_for_lock(path)
            fcntl.flock(fd, fcntl.LOCK_EX)
            if os.path.samestat(os.fstat(fd), os.lstat(path)):
                return fd, path
        except FileNotFoundError:
            pass
        if fd is not None:
            os.close(fd)


def _owner_gone(entry: Path) -> bool:
    """Whether no live process holds the lock of a temporary (its writer was killed)."""
    if fcntl is None:
        return False
    try:
        fd = _open_for_lock(entry)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except OSError:
        return False
    finally:
        os.close(fd)              # the lock goes with it; the entry is removed right after


def _stale(directory: str | os.PathLike, pattern: str, older_than_s: float) -> list[Path]:
    """The entries matching ``pattern`` in ``directory`` whose writer is gone: no process
    holds their lock (every writer here locks its temporaries) or, where locks are not
    available, older than ``older_than_s``. Symbolic links are never taken."""
    found = []
    now = time.time()
    for entry in Path(directory).glob(pattern):
        try:
            if entry.is_symlink():
                continue
            if not _owner_gone(entry) and (fcntl is not None
                                           or now - entry.lstat().st_mtime < older_than_s):
                continue
            found.append(entry)
        except OSError:
            continue
    return found


def remove_stale(directory: str | os.PathLike, pattern: str,
                 older_than_s: float = STALE_AFTER_S) -> list[Path]:
    """Remove the temporaries matching ``pattern`` in ``directory`` that a killed run left.

    An entry is removed when no process holds its lock (its writer is gone: every writer
    here locks its temporaries) or, where locks are not available, when it is older than
    ``older_than_s``. A live writer keeps its files. Errors (an entry vanishing meanwhile,
    no permission) are ignored: cleaning up never stops a write.

    Returns
    -------
    list of Path
        The entries removed.
    """
    removed = []
    for entry in _stale(directory, pattern, older_than_s):
        try:
            if entry.is_dir():
                shutil.rmtree(entry)
            else:
                entry.unlink()
            removed.append(entry)
        except OSError:
            continue
    return removed


def _restore_stale_backups(path: Path) -> list[Path]:
    """Put back the old version of ``path`` that a killed :func:`write_together` kept.

    A run killed between its renames leaves some targets new and some old, with the old
    versions as hard links ``.NAME.<token>.old``: putting every such backup back returns
    the whole set to its old, consistent state (a run killed after its last rename but
    before removing its backups is rolled back the same way: old and consistent).
    Returns the backups put back (the newest first, so the oldest version stays)."""
    stale = _stale(path.parent, f".{glob_escape(path.name)}.*.old", STALE_AFTER_S)
    restored = []
    for backup in sorted(stale, key=lambda p: p.lstat().st_mtime, reverse=True):
        try:
            if path.exists() and os.path.samefile(backup, path):
                backup.unlink()           # not renamed yet (rename() of a link to itself
            else:                         # would leave both names)
                os.replace(backup, path)
            restored.append(backup)
        except OSError:
            continue
    return restored


@contextlib.contextmanager
def temp_dir(directory: str | os.PathLike, prefix: str, suffix: str) -> Iterator[Path]:
    """A locked temporary directory inside ``directory``, removed on exit (whatever
    happened); :func:`remove_stale` leaves it alone while this process lives."""
    fd, path = _hold(lambda: (None, tempfile.mkdtemp(prefix=prefix, suffix=suffix,
                                                      dir=directory)))
    try:
        yield Path(path)
    finally:
        shutil.rmtree(path, ignore_errors=True)
        if fd is not None:
            os.close(fd)


@contextlib.contextmanager
def locked(directory: str | os.PathLike) -> Iterator[None]:
    """Hold ``directory``'s exclusive lock: writers that replace entries of one directory
    take turns (a no-op where the platform has no ``flock``)."""
    if fcntl is None:
        yield
        return
    fd = _open_for_lock(directory)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def atomic_write(path: str | os.PathLike, write: Callable[[str], object]) -> Path:
    """Call ``write(tmp_path)`` for a temporary file next to ``path``, then rename it.

    A failed or interrupted write never leaves a partial file at ``path`` (nor the
    temporary file). The file gets the mode of a normally created file (0666 minus the
    umask), not the temporary file's 0600.

    Parameters
    ----------
    path : path-like
        The file to (re)place.
    write : callable
        Writes the whole content to the path it is given.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(path)
    remove_stale(path.parent, f".{glob_escape(path.name)}.*.tmp")
    fd, tmp = _hold(lambda: tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp",
                                             dir=path.parent))
    try:
        write(tmp)
        _as_if_created(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    finally:
        if fd is not None:
            os.close(fd)
    return path


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically (flushed to disk before the rename)."""
    def write(tmp):
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return atomic_write(path, write)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return write_bytes(path, text.encode("utf-8"))


def jsonable(obj):
    """A copy of ``obj`` that :func:`json.dumps` writes as standard JSON.

    Mappings become dicts with string keys; lists, tuples, sets and arrays become lists;
    numpy scalars become Python scalars; NaN and infinities become ``None`` (JSON has no
    such numbers). Other values are returned as they are.
    """
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple, set, frozenset)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    return obj


def write_together(contents: Mapping[str | os.PathLike, bytes]) -> list[Path]:
    """Write several files as one: all new, or (after any failure) all as they were.

    Every file is first written in full to a temporary file next to its target (the step
    that fails on a full disk or an unwritable directory); only then are the targets
    replaced, one rename each. The old versions are kept as hard links until every rename
    has succeeded, and put back if one fails, so a table never sits beside its old sidecar.
A run killed between its renames leaves its backups behind, locked by no one; the next
write of the same files puts them back first (every file old again), then writes.

    Parameters
    ----------
    contents : mapping of path-like to bytes
        Target path -> its complete content.

    Returns
    -------
    list of Path
        The targets, in the order given.
    """
    targets = [Path(p) for p in contents]
    temps: list[tuple[Path, str]] = []
    backups: dict[Path, str] = {}
    done: list[Path] = []
    locks: list[int] = []
    try:
        for path in targets:                  # a killed run's half-renamed set: old again
            _restore_stale_backups(path)
        for path, data in zip(targets, contents.values()):
            remove_stale(path.parent, f".{glob_escape(path.name)}.*.tmp")
            fd, tmp = _hold(lambda path=path: tempfile.mkstemp(
                prefix=f".{path.name}.", suffix=".tmp", dir=path.parent))
            if fd is not None:
                locks.append(fd)
            temps.append((path, tmp))
            with (os.fdopen(os.dup(fd), "wb") if fd is not None else open(tmp, "wb")) as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
            _as_if_created(tmp)
        for path, _ in temps:
            if path.exists():
                backup = str(path.parent / f".{path.name}.{secrets.token_hex(8)}.old")
                os.link(path, backup)         # fails rather than follows an existing name
                backups[path] = backup
                if fcntl is not None:         # held: a live writer's backup is not stale
                    fd = _open_for_lock(backup)
                    locks.append(fd)
                    fcntl.flock(fd, fcntl.LOCK_EX)
        for path, tmp in temps:
            os.replace(tmp, path)
            done.append(path)
    except BaseException:
        for path in done:                     # put the old versions back
            if path in backups:
                os.replace(backups.pop(path), path)
            else:
                path.unlink(missing_ok=True)
        for _, tmp in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise
    finally:
        for backup in backups.values():
            if os.path.exists(backup):
                os.unlink(backup)
        for fd in locks:
            os.close(fd)
    return targets
