"""Credentials for tests of plain links on loopback: a secret long enough, in a 0600 file."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["TEST_SECRET", "write_secret"]

TEST_SECRET = b"0123456789abcdef0123456789abcdef-tests"
"""A secret the mesh and Zenoh accept for plain links (32 bytes or more)."""


def write_secret(directory: Path, secret: bytes = TEST_SECRET, name: str = "secret") -> Path:
    """Write ``secret`` to a new file only its owner can read; returns its path."""
    path = directory / name
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as handle:
        handle.write(secret)
    return path
