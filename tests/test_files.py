"""Files are written whole or not at all: single files and groups (a table and its sidecar)."""

from __future__ import annotations

import os
import time

import pytest

from simplexspline import _files
from simplexspline._files import write_text, write_together


def _listing(d):
    return sorted(p.name for p in d.iterdir())


def test_write_together_writes_all_and_leaves_no_temporaries(tmp_path):
    a, b = tmp_path / "t.csv", tmp_path / "t.csv.json"
    assert write_together({a: b"x,y\n", b: b"{}"}) == [a, b]
    assert a.read_bytes() == b"x,y\n" and b.read_bytes() == b"{}"
    assert write_together({a: b"new", b: b"[]"}) == [a, b]
    assert (a.read_bytes(), b.read_bytes()) == (b"new", b"[]")
    assert _listing(tmp_path) == ["t.csv", "t.csv.json"]


def test_a_failed_write_keeps_the_old_pair(tmp_path, monkeypatch):
    a, b = tmp_path / "t.csv", tmp_path / "t.csv.json"
    write_together({a: b"old table", b: b"old sidecar"})
    real = os.fdopen
    calls = []

    def full_disk(fd, *args, **kwargs):
        calls.append(fd)
        if len(calls) == 2:                       # the sidecar's write: disk full
            os.close(fd)
            raise OSError(28, "No space left on device")
        return real(fd, *args, **kwargs)

    monkeypatch.setattr(os, "fdopen", full_disk)
    with pytest.raises(OSError, match="No space left"):
        write_together({a: b"new table", b: b"new sidecar"})
    assert (a.read_bytes(), b.read_bytes()) == (b"old table", b"old sidecar")
    assert _listing(tmp_path) == ["t.csv", "t.csv.json"]


def _fail_second_rename(monkeypatch, second):
    """Make the rename of a temporary onto ``second`` fail (EIO); returns the real
    ``os.replace``."""
    real = os.replace

    def second_rename_fails(src, dst):
        if str(dst) == str(second) and str(src).endswith(".tmp"):
            raise OSError(5, "Input/output error")
        return real(src, dst)

    monkeypatch.setattr(os, "replace", second_rename_fails)
    return real


def test_a_failed_rename_puts_the_first_file_back(tmp_path, monkeypatch):
    a, b = tmp_path / "t.npz", tmp_path / "t.npz.json"
    write_together({a: b"old table", b: b"old sidecar"})
    real = _fail_second_rename(monkeypatch, b)
    with pytest.raises(OSError, match="Input/output"):
        write_together({a: b"new table", b: b"new sidecar"})
    assert (a.read_bytes(), b.read_bytes()) == (b"old table", b"old sidecar")
    assert _listing(tmp_path) == ["t.npz", "t.npz.json"]


def test_a_failed_first_write_of_a_new_pair_leaves_nothing(tmp_path, monkeypatch):
    def broken(fd, *args, **kwargs):
        os.close(fd)
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fdopen", broken)
    with pytest.raises(OSError):
        write_together({tmp_path / "a": b"1", tmp_path / "b": b"2"})
    assert _listing(tmp_path) == []


def test_write_text_is_atomic_under_a_failing_writer(tmp_path):
    target = tmp_path / "m.json"
    write_text(target, "old")

    def fails(tmp):
        with open(tmp, "w") as fh:
            fh.write("half")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        _files.atomic_write(target, fails)
    assert target.read_text() == "old"
    assert _listing(tmp_path) == ["m.json"]


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_written_files_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        write_text(tmp_path / "one.json", "{}")
        write_together({tmp_path / "t.csv": b"x", tmp_path / "t.csv.json": b"{}"})
    finally:
        os.umask(old)
    for name in ("one.json", "t.csv", "t.csv.json"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~mask


def _live_writer(path):
    """Hold ``path``'s lock as a writer at work does (released when the descriptor closes)."""
    fcntl = pytest.importorskip("fcntl")
    fd = os.open(path, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)
    return fd


def test_stale_temporaries_of_a_killed_run_are_removed_by_the_next_write(tmp_path):
    """A temporary nobody holds (its writer was killed) goes at the next write to the same
    target, however young; a live writer's stays, and so do other targets' temporaries."""
    target = tmp_path / "model.json"
    stale = tmp_path / ".model.json.abc123.tmp"
    fresh = tmp_path / ".model.json.def456.tmp"          # a writer still at work
    other = tmp_path / ".other.json.xyz.tmp"
    for p in (stale, fresh, other):
        p.write_text("partial")
    fd = _live_writer(fresh)
    try:
        write_text(target, "{}")
        assert _listing(tmp_path) == sorted([".model.json.def456.tmp", ".other.json.xyz.tmp",
                                             "model.json"])
    finally:
        os.close(fd)
    write_text(target, "{}")                             # the writer is gone now
    assert _listing(tmp_path) == sorted([".other.json.xyz.tmp", "model.json"])


def test_remove_stale_takes_directories_and_keeps_live_ones(tmp_path):
    dead = tmp_path / ".identify.1.tmp"
    (dead / "models").mkdir(parents=True)
    live = tmp_path / ".identify.2.tmp"
    live.mkdir()
    fd = _live_writer(live)
    try:
        assert _files.remove_stale(tmp_path, ".identify.*") == [dead]
        assert _listing(tmp_path) == [".identify.2.tmp"]
    finally:
        os.close(fd)


def test_remove_stale_without_locks_goes_by_age(tmp_path, monkeypatch):
    """Where the platform has no flock, only temporaries older than STALE_AFTER_S go."""
    monkeypatch.setattr(_files, "fcntl", None)
    old_dir = tmp_path / ".identify.1.tmp"
    (old_dir / "models").mkdir(parents=True)
    (tmp_path / ".identify.2.tmp").mkdir()
    old = time.time() - 2 * _files.STALE_AFTER_S
    os.utime(old_dir, (old, old))
    assert _files.remove_stale(tmp_path, ".identify.*") == [old_dir]
    assert _listing(tmp_path) == [".identify.2.tmp"]


def test_temporaries_are_locked_while_written(tmp_path):
    """A writer's own temporary file and directory survive another writer's clean-up."""
    seen = []

    def write(tmp):
        seen.append(_files.remove_stale(tmp_path, ".*.tmp"))
        with open(tmp, "w") as fh:
            fh.write("x")

    _files.atomic_write(tmp_path / "a.txt", write)
    with _files.temp_dir(tmp_path, ".identify.", ".tmp") as d:
        assert _files.remove_stale(tmp_path, ".identify.*") == [] and d.is_dir()
    assert seen == [[]] and _listing(tmp_path) == ["a.txt"]



def test_writes_without_locks(tmp_path, monkeypatch):
    """Where there is no flock, writes work the same (no descriptor is held open)."""
    monkeypatch.setattr(_files, "fcntl", None)
    write_text(tmp_path / "a.txt", "x")
    write_together({tmp_path / "t.csv": b"t", tmp_path / "t.csv.json": b"{}"})
    with _files.temp_dir(tmp_path, ".identify.", ".tmp") as d:
        assert d.is_dir()
    assert _listing(tmp_path) == ["a.txt", "t.csv", "t.csv.json"]


def _killed_between_renames(a, b):
    """Run write_together({a: new, b: new}) in a child that SIGKILLs itself between its
    two renames (the first file new, the second old, both backups left behind)."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(f"""
        import os, signal
        from simplexspline._files import write_together
        real = os.replace
        def replace(src, dst):
            if str(dst) == {str(b)!r} and str(src).endswith(".tmp"):
                os.kill(os.getpid(), signal.SIGKILL)
            return real(src, dst)
        os.replace = replace
        write_together({{{str(a)!r}: b"new table", {str(b)!r}: b"new sidecar"}})
    """)
    res = subprocess.run([sys.executable, "-c", code], timeout=120)
    assert res.returncode == -9


@pytest.mark.skipif(os.name != "posix", reason="SIGKILL")
def test_a_run_killed_between_renames_is_rolled_back_by_the_next(tmp_path, monkeypatch):
    """The killed run leaves a new table beside the old sidecar, and its backups. The next
    write puts the old pair back first: if that write fails too, the pair is old and
    consistent; when it succeeds, new and consistent, with no backup left behind."""
    a, b = tmp_path / "t.csv", tmp_path / "t.csv.json"
    write_together({a: b"old table", b: b"old sidecar"})
    _killed_between_renames(a, b)
    assert (a.read_bytes(), b.read_bytes()) == (b"new table", b"old sidecar")
    assert sum(p.name.endswith(".old") for p in tmp_path.iterdir()) == 2

    real = _fail_second_rename(monkeypatch, b)
    with pytest.raises(OSError, match="Input/output"):
        write_together({a: b"third table", b: b"third sidecar"})
    assert (a.read_bytes(), b.read_bytes()) == (b"old table", b"old sidecar")
    assert _listing(tmp_path) == ["t.csv", "t.csv.json"]

    monkeypatch.setattr(os, "replace", real)
    _killed_between_renames(a, b)
    write_together({a: b"fourth table", b: b"fourth sidecar"})
    assert (a.read_bytes(), b.read_bytes()) == (b"fourth table", b"fourth sidecar")
    assert _listing(tmp_path) == ["t.csv", "t.csv.json"]


@pytest.mark.skipif(os.name != "posix", reason="flock")
def test_a_live_writers_backups_are_not_taken(tmp_path):
    """While a write holds its backups (locked), another write of the same files must not
    take them for a killed run's."""
    import fcntl

    a = tmp_path / "t.csv"
    write_together({a: b"current"})
    backup = tmp_path / ".t.csv.0123456789abcdef.old"
    os.link(a, backup)
    fd = os.open(backup, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        assert _files._restore_stale_backups(a) == []
        assert backup.exists()
    finally:
        os.close(fd)
    assert _files._restore_stale_backups(a) == [backup]      # its writer is gone
    assert not backup.exists() and a.read_bytes() == b"current"
