"""The order store's file: who owns it, how it is made, and what opening it refuses.

Ownership: an exclusive ``flock`` on ``<file>.lock`` (held while the store is open,
released by the kernel when the process dies, whatever kills it) names the holder's
pid; SQLite's exclusive locking mode keeps any other program from writing behind the
owner's back. A missing file is the only fresh start: it is made whole under a
temporary name and renamed into place, so a file at the path is always a complete store.
Everything else that is not a whole order store of this version is refused, with a
:class:`StoreError` that names the file and why.
"""

from __future__ import annotations

import fcntl
import os
import sqlite3
from pathlib import Path

__all__ = ["APPLICATION_ID", "SCHEMA_VERSION", "StoreError", "connect", "lock", "unlock"]

SCHEMA_VERSION = 1
"""The layout this module reads and writes."""

APPLICATION_ID = 0x4F504F42
"""SQLite header's application id of an order store ("OPOB")."""


_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL) WITHOUT ROWID;
CREATE TABLE tasks (
    n INTEGER PRIMARY KEY,
    id TEXT NOT NULL UNIQUE,
    pick TEXT NOT NULL,
    drop_at TEXT NOT NULL,
    creator TEXT NOT NULL,
    state TEXT NOT NULL,
    vehicle TEXT,
    history TEXT NOT NULL,
    closed INTEGER UNIQUE
);
CREATE TABLE events (
    seq INTEGER PRIMARY KEY,
    time REAL NOT NULL,
    severity TEXT NOT NULL,
    source TEXT NOT NULL,
    text TEXT NOT NULL
);
"""


class StoreError(RuntimeError):
    """An order store cannot be opened or written; the message names the file and why,
    fit for a command line."""


def lock(path: Path) -> int:
    """Take ``<path>.lock`` for this process and write its pid there; its descriptor.

    Raises:
        StoreError: another process holds it, or it cannot be opened.
    """
    if not path.parent.is_dir():
        raise StoreError(f"order store {path}: no folder {path.parent}")
    lock_path = path.with_name(path.name + ".lock")
    try:
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise StoreError(f"order store {path}: cannot open {lock_path}: {exc.strerror}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
        os.close(fd)
        pid = f"pid {holder}" if holder.isdigit() else "pid unknown"
        raise StoreError(
            f"order store {path} is in use by another control ({pid}); "
            "one control per store: stop that one, or give this one another file"
        ) from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
    return fd


def unlock(fd: int) -> None:
    """Give up the lock :func:`lock` took."""
    fcntl.flock(fd, fcntl.LOCK_UN)
    os.close(fd)


def connect(path: Path, busy_timeout: float) -> sqlite3.Connection:
    """Open (or make) the store's file and check it is a whole order store of ours.

    Raises:
        StoreError: it is not (the message says why).
    """
    wal = path.with_name(path.name + "-wal")
    if not path.exists():
        if wal.exists():
            raise StoreError(
                f"order store {path} is missing but its write-ahead log {wal} is there: "
                "not starting afresh (put the store back, or remove the log)"
            )
        _create(path)
    elif not path.is_file():
        raise StoreError(f"order store {path} is not a file")
    elif path.stat().st_size == 0:
        raise StoreError(
            f"order store {path} is an empty file, no order store (a new store is made "
            "only where no file is)"
        )
    try:
        # Not bound to the opening thread: the one thread of control that touches a store
        # may be another than the one that opened it (a test client's, a server's).
        db = sqlite3.connect(
            path, timeout=busy_timeout, isolation_level=None, check_same_thread=False
        )
    except sqlite3.Error as exc:
        raise StoreError(f"order store {path} cannot be opened: {exc}") from None
    try:
        _check(path, db)
    except BaseException:
        db.close()
        raise
    return db


def _check(path: Path, db: sqlite3.Connection) -> None:
    try:
        db.execute("PRAGMA locking_mode = EXCLUSIVE")
        (app,) = db.execute("PRAGMA application_id").fetchone()
        if app != APPLICATION_ID:
            raise StoreError(
                f"order store {path} is an SQLite database but no order store "
                f"(application id {app:#x}, an order store's is {APPLICATION_ID:#x})"
            )
        problems = [str(row[0]) for row in db.execute("PRAGMA quick_check(5)")]
        if problems != ["ok"]:
            raise StoreError(f"order store {path} is damaged: {'; '.join(problems)}")
        (mode,) = db.execute("PRAGMA journal_mode = WAL").fetchone()
        if mode != "wal":
            raise StoreError(f"order store {path} cannot keep a write-ahead log (mode {mode})")
        db.execute("PRAGMA synchronous = FULL")
        db.execute("BEGIN IMMEDIATE")  # takes the exclusive lock, kept until closed
        try:
            meta = dict(db.execute("SELECT key, value FROM meta").fetchall())
            version = meta.get("schema")
            if version != str(SCHEMA_VERSION) or "created" not in meta:
                raise StoreError(
                    f"order store {path} has schema version {version}; this program reads "
                    f"version {SCHEMA_VERSION} only"
                )
            db.execute(
                "INSERT OR REPLACE INTO meta (key, value) VALUES ('holder', ?)", (str(os.getpid()),)
            )
        except BaseException:
            db.execute("ROLLBACK")
            raise
        db.execute("COMMIT")
    except sqlite3.Error as exc:
        raise StoreError(_refusal(path, exc)) from None


def _refusal(path: Path, exc: sqlite3.Error) -> str:
    text = str(exc)
    if "locked" in text or "busy" in text:
        return f"order store {path} is locked by another process ({text})"
    if "no such table" in text:
        return f"order store {path} is damaged ({text})"
    if "not a database" in text:
        return f"order store {path} is not an SQLite database ({text})"
    if isinstance(exc, sqlite3.DatabaseError) and not isinstance(exc, sqlite3.OperationalError):
        return f"order store {path} is damaged ({text})"
    return f"order store {path} cannot be opened: {text}"


def _create(path: Path) -> None:
    """Make an empty store at ``path``: whole under a temporary name, then renamed."""
    new = path.with_name(path.name + ".new")
    for leftover in (new, new.with_name(new.name + "-journal")):
        leftover.unlink(missing_ok=True)  # a creation cut short, under our lock
    try:
        db = sqlite3.connect(new, isolation_level=None)
        try:
            db.executescript(
                f"BEGIN; PRAGMA application_id = {APPLICATION_ID}; {_SCHEMA} "
                f"INSERT INTO meta (key, value) VALUES ('schema', '{SCHEMA_VERSION}'), "
                "('created', '0'); COMMIT;"
            )
        finally:
            db.close()
        fd = os.open(new, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(new, path)
        fd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
    except (OSError, sqlite3.Error) as exc:
        raise StoreError(f"order store {path} cannot be made: {exc}") from None
