"""Files written so that a kill at any moment leaves the old files or the new ones: staged
temporary files beside their targets, moved into place together (``write_together``); stale
temporary files of killed processes removed; directories locked by one process at a time.
"""
from __future__ import annotations

import csv
import fcntl
import glob
import io
import os
import tempfile
from pathlib import Path

from ..models.spec import ParameterError


class _Staged:
    """Collects (final path, temporary path) pairs; ``commit`` moves all of them into place."""

    def __init__(self):
        self.pairs: list[tuple[Path, str]] = []

    def open(self, path: Path, mode: str = "wb"):
        path = Path(path)
        remove_stale(path)
        fd, tmp = tempfile.mkstemp(dir=str(path.parent) or ".", prefix=tmp_prefix(path),
                                   suffix=".tmp")
        self.pairs.append((path, tmp))
        return os.fdopen(fd, mode, **({} if "b" in mode else {"newline": "", "encoding": "utf-8"}))

    def commit(self) -> list[Path]:
        for path, tmp in self.pairs:
            try:    # keep the permissions a plain open() would have given
                umask = os.umask(0)
                os.umask(umask)
                os.chmod(tmp, 0o666 & ~umask)
            except OSError:
                pass
        # keep the old files as hard links until every new one is in place, so that a failed
        # replace (of the second file, say) restores the first: all old files or all new ones
        backups = []
        try:
            for path, _ in self.pairs:
                if path.exists():
                    b = path.with_name(tmp_prefix(path) + "old.tmp")
                    if b.exists():
                        b.unlink()
                    os.link(path, b)
                    backups.append((path, b))
            done_pairs = []
            try:
                for path, tmp in self.pairs:
                    os.replace(tmp, path)
                    done_pairs.append(path)
            except BaseException:
                for path, b in backups:
                    if path in done_pairs:
                        os.replace(b, path)
                for path in done_pairs:
                    if path not in dict(backups):
                        path.unlink()
                raise
        finally:
            for _, b in backups:
                if b.exists():
                    b.unlink()
        done = [p for p, _ in self.pairs]
        self.pairs = []
        return done

    def discard(self):
        for _, tmp in self.pairs:
            try:
                os.unlink(tmp)
            except FileNotFoundError:
                pass
        self.pairs = []


def tmp_prefix(path: Path, pid: int | None = None) -> str:
    """Temporary files are .NAME.PID.XXXXXXXX.tmp beside NAME: a later run can tell whose they are."""
    return f".{path.name}.{os.getpid() if pid is None else pid}."


def remove_stale(path: Path) -> None:
    """Remove temporary files of ``path`` left by a process that no longer runs (SIGKILL)."""
    path = Path(path)
    parent = path.parent if str(path.parent) else Path(".")
    try:
        entries = list(parent.glob(f".{glob_escape(path.name)}.*.tmp"))
    except OSError:
        return
    for e in entries:
        pid = e.name[len(path.name) + 2:].split(".", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not alive(int(pid)):
            try:
                e.unlink()
            except OSError:
                pass


def glob_escape(name: str) -> str:
    return glob.escape(name)


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def probe_directory(out) -> None:
    """Before any work: the directory of ``out`` exists and takes new files (a probe file is
    created and removed, which also catches read-only file systems). Raises ValueError."""
    parent = Path(out).parent if str(Path(out).parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"directory {str(parent)!r} does not exist")
    try:
        fd, probe = tempfile.mkstemp(dir=str(parent), prefix=tmp_prefix(Path(out)), suffix=".tmp")
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise ValueError(f"cannot write in directory {str(parent)!r}: {e.strerror or e}") from None


def _sync_close(f):
    f.flush()
    os.fsync(f.fileno())
    f.close()


def csv_text(rows, fields) -> str:
    """Rows (dicts) as CSV text with a header line; keys not in ``fields`` are left out."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=fields, extrasaction="ignore")
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def csv_rows(path, floats=(), without=None) -> list:
    """The rows (dicts) of a CSV file written by ``csv_text``, the ``floats`` columns as
    numbers; ``without``: leave out the rows whose "model" is in it. [] if there is no file."""
    path = Path(path)
    if not path.exists():
        return []
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if without is None or r.get("model") not in without]
    for r in rows:
        for k in floats:
            r[k] = float(r[k])
    return rows


def write_together(files: dict) -> None:
    """Write {path: bytes or str} so that a kill at any moment leaves all the old files or all
    the new ones (staged temporary files, moved into place together)."""
    staged = _Staged()
    try:
        for path, data in files.items():
            f = staged.open(Path(path), "wb" if isinstance(data, bytes) else "w")
            f.write(data)
            _sync_close(f)
        staged.commit()
    except BaseException:
        staged.discard()
        raise


def lock_dir(path: Path):
    """An exclusive lock on a directory (a table's checkpoint, a sweep's store): flock on its
    descriptor, released when the process ends however it ends; returns the descriptor to close,
    or raises a ParameterError if another process holds it."""
    fd = os.open(path, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(fd)
        raise ParameterError(f"another clbrdf process is computing into {str(path)!r} now (it "
                             f"holds its lock): wait for it to finish, or write another output") \
            from None
    return fd
