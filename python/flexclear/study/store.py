"""The store: Parquet parts written atomically, the definition beside them, the writer's lock, and
the progress of a run."""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import time
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np

from ..errors import (
    InvalidParameterError,
    StoreError,
    StoreLockedError,
)
from .definition import Study


class _PartWriter:
    """Collects finished rows (into ``frames``, which the caller's result is made of) and writes
    them to the store as one part when asked, or when :data:`FLUSH_SECONDS` have passed since the
    last write. A failed write raises :class:`StoreError`; its rows stay in ``frames``."""

    def __init__(self, store_: Optional[_Store], frames: list) -> None:
        self.store = store_
        self.frames = frames
        self.pending: list = []
        self.last = time.monotonic()

    def add(self, frame) -> None:
        if len(frame):
            self.frames.append(frame)
            if self.store is not None:
                self.pending.append(frame)

    def flush_if_due(self) -> None:
        if time.monotonic() - self.last >= FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        self.last = time.monotonic()
        if not self.pending:
            return
        import pandas as pd

        frame = pd.concat(self.pending) if len(self.pending) > 1 else self.pending[0]
        try:
            self.store.write(frame)  # type: ignore[union-attr]
        except OSError as e:
            path = self.store.path  # type: ignore[union-attr]
            raise _store_error(
                path,
                f"writing {len(frame)} finished samples failed ({type(e).__name__}: {e}); every sample "
                "computed by this run is in exc.partial, and those written before are safe in the store: "
                "fix the cause (space, permissions) and run again to resume",
            ) from e
        self.pending = []


class _Store:
    """A study's folder: the definition (``study.json``), the inputs, and Parquet parts of results.

    A writer holds ``writer.lock`` (its pid, host and start time) for as long as it runs; a second
    writer is refused with :class:`StoreLockedError`, and a lock whose owner is dead (on this
    host) is taken over. Parts are named by the samples they hold, written to a temporary file
    named after the writer and renamed whole; a reader de-duplicates samples and refuses two
    different results for one sample. ``write=False`` opens a store for reading only (no lock).
    """

    def __init__(self, path: Path, study: Study, *, write: bool = True) -> None:
        self.path = path
        self.study = study
        self._lock: Optional[_Lock] = None
        meta = path / "study.json"
        if not write:
            if not meta.exists():
                raise InvalidParameterError(f"{str(path)!r} is not a study store (no study.json)")
            self._check_definition(meta)
            return
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise _store_error(path, f"the store folder cannot be created: {e}") from None
        self._lock = _Lock(path)
        self._lock.acquire()  # also checks that the folder is writable
        try:
            if meta.exists():
                self._check_definition(meta)
            else:
                _write_parquet(study.inputs(), path / "inputs.parquet")
                _write_text(
                    meta,
                    json.dumps(
                        {
                            "fingerprint": study.fingerprint(),
                            "study": study.to_dict(),
                            "report_thresholds": study.report_thresholds,
                        },
                        indent=2,
                        default=float,
                    ),
                )
            self._remove_dead_temporaries()
            _probe_write(path)
        except OSError as e:
            self.close()
            if isinstance(e, StoreError):
                raise
            raise _store_error(path, f"the store is not writable: {e}") from None
        except BaseException:
            self.close()
            raise

    def read_pilot(self) -> Optional[dict]:
        """The pilot kept in the store (``pilot.json``), or None."""
        f = self.path / "pilot.json"
        return json.loads(f.read_text()) if f.exists() else None

    def write_pilot(self, pilot: dict) -> None:
        """Keeps the pilot of a study with ``tol`` in the store (``pilot.json``)."""
        _write_text(self.path / "pilot.json", json.dumps(pilot, indent=2, default=float))

    def _check_definition(self, meta: Path) -> None:
        study = self.study
        fp = study.fingerprint()
        stored = json.loads(meta.read_text())
        if stored.get("fingerprint") == fp:
            return
        old = json.loads(json.dumps(stored.get("study", {}), sort_keys=True, default=float))
        new = json.loads(json.dumps(study.to_dict(), sort_keys=True, default=float))
        changed = [
            f"{k} (stored {old.get(k, '<absent>')!r}, now {new.get(k, '<absent>')!r})"
            for k in sorted(set(old) | set(new))
            if old.get(k, "<absent>") != new.get(k, "<absent>")
        ]
        raise InvalidParameterError(
            f"store {str(self.path)!r} holds a different study (fingerprint {stored.get('fingerprint')}, "
            f"this one {fp}); changed: {'; '.join(changed) or 'the definition format'}; "
            "use another folder or delete it"
        )

    def _remove_dead_temporaries(self) -> None:
        """Temporary files of writers that died mid-write (never those of a live process)."""
        host = _host()
        for tmp in self.path.glob("*.tmp"):
            owner = _tmp_owner(tmp.name)
            if owner is None:
                # no owner in the name (an older flexclear): only when clearly abandoned
                try:
                    stale = time.time() - tmp.stat().st_mtime > 600.0
                except OSError:
                    continue
            else:
                pid, h = owner
                stale = h == host and (pid == os.getpid() or not _pid_alive(pid))
            if stale:
                tmp.unlink(missing_ok=True)

    def close(self) -> None:
        """Releases the writer's lock (a store opened for reading holds none)."""
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def read(self) -> list:
        """The stored rows as a list of at most one DataFrame, each sample once. Raises
        :class:`StoreError` when two parts hold different results for one sample, or a part
        cannot be read."""
        import pandas as pd

        parts, names = [], []
        for p in sorted(self.path.glob("part-*.parquet")):
            try:
                parts.append(pd.read_parquet(p))
            except FileNotFoundError:
                continue
            except Exception as e:  # a damaged file: say which
                raise _store_error(
                    self.path,
                    f"part {p.name!r} cannot be read ({type(e).__name__}: {e}); move it out of the store "
                    "and run again to recompute its samples",
                ) from None
            names.append(p.name)
        if not parts:
            return []
        source = np.concatenate([np.full(len(f), k) for k, f in enumerate(parts)])
        frame = pd.concat(parts)
        dup = frame.index.duplicated(keep=False)
        if dup.any():
            first = ~frame.index.duplicated(keep="first")
            rows = np.flatnonzero(dup)
            firsts = {}
            for r in rows:
                i = frame.index[r]
                if i not in firsts:
                    firsts[i] = r
                    continue
                column = _first_difference(frame.iloc[firsts[i]], frame.iloc[r])
                if column is not None:
                    a, b = frame.iloc[firsts[i]][column], frame.iloc[r][column]
                    raise _store_error(
                        self.path,
                        f"sample {i} has two different results: {column} = {a!r} in "
                        f"{names[source[firsts[i]]]!r} and {b!r} in {names[source[r]]!r} (the store was "
                        "written by different flexclear versions or corrupted); move one part out of the "
                        "store",
                    )
            frame = frame[first]
        return [frame]

    def write(self, frame) -> None:
        """Writes ``frame`` (rows indexed by sample) as one part named by its samples."""
        if not len(frame):
            return
        _write_parquet(frame, self.path / _part_name([int(i) for i in frame.index]))


#: Name of the writer's lock file in a store.
LOCK_FILE = "writer.lock"
#: Finished samples are written to the store at least this often while a chunk runs, s.
FLUSH_SECONDS = 5.0


def _store_error(path: Path, message: str, cls: Optional[type] = None) -> Any:
    e = (cls or StoreError)(f"store {str(path)!r}: {message}")
    e.path = str(path)
    return e


def _host() -> str:
    import socket

    return socket.gethostname()


def _proc_stat(pid: int) -> Optional[tuple[str, str]]:
    """``(state, start time in clock ticks since boot)`` of process ``pid`` from
    ``/proc/<pid>/stat``; None where there is no such file."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rfind(")") + 2 :].split()
    return (fields[0], fields[19]) if len(fields) > 19 else None


def _pid_alive(pid: int, started: Optional[str] = None) -> bool:
    """Whether process ``pid`` of this host is alive (and, with ``started``, is the same process:
    a reused pid is not). Where that cannot be told (Windows), True."""
    if not isinstance(pid, int) or pid <= 0:
        return False
    if os.name == "nt":  # os.kill would terminate it
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # alive, another user's
    stat = _proc_stat(pid)
    if stat is not None:
        state, start = stat
        if state in ("Z", "X"):  # a zombie: dead, not yet reaped
            return False
        if started is not None and start != str(started):
            return False
    return True


def _me() -> dict:
    stat = _proc_stat(os.getpid())
    return {
        "pid": os.getpid(),
        "host": _host(),
        "started": stat[1] if stat else None,
        "since": time.strftime("%Y-%m-%d %H:%M:%S"),
    }


def _tmp_suffix() -> str:
    return f".{os.getpid()}@{_host()}.tmp"


def _tmp_owner(name: str) -> Optional[tuple[int, str]]:
    """``(pid, host)`` of a temporary file named by :func:`_tmp_suffix`, else None."""
    left, at, host = name[: -len(".tmp")].rpartition("@")
    pid = left.rsplit(".", 1)[-1]
    if not at or not pid.isdigit():
        return None
    return int(pid), host


def _part_name(ids: list[int]) -> str:
    """A part's file name from its samples: first and last, and a digest of all (so that the
    same samples always give the same name, and a rerun overwrites rather than duplicates)."""
    digest = hashlib.sha256(",".join(map(str, sorted(ids))).encode()).hexdigest()[:12]
    return f"part-{min(ids):09d}-{max(ids):09d}-{digest}.parquet"


def _first_difference(a, b) -> Optional[str]:
    """The first column (but the wall-clock time) where two stored rows of one sample differ."""
    for c in a.index:
        if c == "wall_time":
            continue
        x, y = a[c], b[c]
        if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            if not np.array_equal(np.asarray(x), np.asarray(y), equal_nan=True):
                return c
        elif x != y and not (_isnan(x) and _isnan(y)):
            return c
    return None


def _isnan(x) -> bool:
    return isinstance(x, (float, np.floating)) and math.isnan(x)


class _Guard:
    """An exclusive ``flock`` on ``.writer.lock.guard`` while the lock file is examined, so that two
    processes of one host taking over a stale lock cannot both win (no-op without fcntl)."""

    def __init__(self, path: Path) -> None:
        self.file = path / ".writer.lock.guard"
        self.fd: Optional[int] = None

    def __enter__(self) -> _Guard:
        try:
            import fcntl
        except ImportError:  # Windows
            return self
        try:
            self.fd = os.open(self.file, os.O_CREAT | os.O_RDWR, 0o644)
        except OSError as e:
            raise _store_error(self.file.parent, f"the store is not writable: {e}") from None
        fcntl.flock(self.fd, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            os.close(self.fd)  # releases the flock
            self.fd = None


class _Lock:
    """The writer's lock file: created whole (written to a private file, then hard-linked to its
    name, which fails when it exists), holding the owner's pid, host and start time."""

    def __init__(self, path: Path) -> None:
        self.dir = path
        self.file = path / LOCK_FILE
        self.me = _me()
        self.held = False

    def owner(self) -> Optional[dict]:
        try:
            data = json.loads(self.file.read_text())
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}
        return data if isinstance(data, dict) else {}

    def _stale(self, owner: dict) -> bool:
        if not owner:  # unreadable: a writer killed mid-creation (O_EXCL fallback), if old
            try:
                return time.time() - self.file.stat().st_mtime > 60.0
            except OSError:
                return True
        return owner.get("host") == self.me["host"] and not _pid_alive(owner.get("pid"), owner.get("started"))

    def acquire(self) -> None:
        body = json.dumps(self.me).encode()
        with _Guard(self.dir):
            for _ in range(3):
                tmp = self.dir / (LOCK_FILE + _tmp_suffix())
                try:
                    with open(tmp, "wb") as f:
                        f.write(body)
                        f.flush()
                        os.fsync(f.fileno())
                except OSError as e:
                    tmp.unlink(missing_ok=True)
                    raise _store_error(self.dir, f"the store is not writable: {e}") from None
                try:
                    try:
                        os.link(tmp, self.file)
                    except FileExistsError:
                        raise
                    except OSError:  # no hard links here: exclusive creation instead
                        fd = os.open(self.file, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
                        with os.fdopen(fd, "wb") as f:
                            f.write(body)
                    self.held = True
                    return
                except FileExistsError:
                    owner = self.owner()
                    if owner is None:
                        continue  # released meanwhile
                    if self._stale(owner):
                        self.file.unlink(missing_ok=True)
                        continue
                    raise self._locked(owner) from None
                finally:
                    tmp.unlink(missing_ok=True)
        raise self._locked(self.owner() or {})

    def _locked(self, owner: dict) -> StoreLockedError:
        who = f"process {owner.get('pid', '?')} on host {owner.get('host', '?')!r}"
        since = f" since {owner['since']}" if owner.get("since") else ""
        e = _store_error(
            self.dir,
            f"another writer holds it: {who}{since} (one writer per store; wait for it to finish, "
            f"or read it with flexclear.study.open_store). If that process is gone (on another host, or "
            f"the lock is left over), delete {str(self.file)!r}",
            StoreLockedError,
        )
        e.owner = dict(owner)
        return e

    def release(self) -> None:
        if not self.held:
            return
        self.held = False
        with contextlib.suppress(OSError):
            owner = self.owner()
            if owner and owner.get("pid") == self.me["pid"] and owner.get("started") == self.me["started"]:
                self.file.unlink()


def _fsync(path: Path) -> None:
    """Flushes a file, or a folder's entries, to the disk (where the platform allows: a folder
    cannot be opened on Windows, nor fsynced on some file systems). A file is opened for writing
    (Windows flushes only such handles)."""
    folder = path.is_dir()
    try:
        fd = os.open(path, os.O_RDONLY if folder else os.O_RDWR)
    except OSError:
        if folder:
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not folder:
            raise
    finally:
        os.close(fd)


def _write_whole(path: Path, write: Callable[[Path], None]) -> None:
    """Writes a store file whole: ``write`` fills a temporary file named after this writer,
    which is flushed to the disk and then renamed to ``path`` (and the rename flushed too).
    Readers take no lock: they see the file whole or not at all, while the writer runs (the
    rename is atomic) and after a crash of the machine (the data is on the disk before the name
    points at it; without the flush a crash could leave a named but empty part)."""
    tmp = path.with_name(path.name + _tmp_suffix())
    try:
        write(tmp)
        _fsync(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # e.g. Ctrl-C mid-write: leave no half-written file
        raise
    _fsync(path.parent)


def _write_text(path: Path, text: str) -> None:
    _write_whole(path, lambda tmp: tmp.write_text(text))


def _probe_write(path: Path) -> None:
    """Writes (and removes) a small file: a store on a full disk or a read-only mount fails here,
    before any sample runs."""
    probe = path / (".probe" + _tmp_suffix())
    try:
        with open(probe, "wb") as f:
            f.write(b"\0" * 65536)
            f.flush()
            os.fsync(f.fileno())
    finally:
        probe.unlink(missing_ok=True)


def _write_parquet(frame, path: Path) -> None:
    _write_whole(path, frame.to_parquet)


class _Progress:
    def __init__(self, progress, total: int, initial: int) -> None:
        self.n = initial
        self.total = total
        self._cb = progress if callable(progress) else None
        self._bar = None
        if progress is True:
            from tqdm.auto import tqdm

            self._bar = tqdm(total=total, initial=initial, unit="sample", smoothing=0.1)

    def update_to(self, n: int) -> None:
        if n == self.n:
            return
        if self._bar is not None:
            self._bar.update(n - self.n)
        self.n = n
        if self._cb is not None:
            self._cb(n, self.total)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
