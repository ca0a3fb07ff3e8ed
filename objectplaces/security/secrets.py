"""Secrets: read from files only their owner can read, long enough, one key per purpose.

A secret protects a plain link on loopback (``insecure=True``) and nothing off it; a
fleet across hosts uses certificates (``objectplaces.security.pki``). Either way the
secret itself never serves twice: ``derive_key`` makes a separate key for each purpose
(the mesh handshake, Zenoh's user name, Zenoh's password) with HKDF-SHA256, so a key
that leaks from one use says nothing of the others.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Final

from cryptography.hazmat.primitives import hashes
from cryptography.hazmat.primitives.kdf.hkdf import HKDF

from objectplaces.security.errors import CredentialError

__all__ = [
    "MIN_SECRET_BYTES",
    "check_private_file",
    "check_secret",
    "derive_key",
    "read_secret_file",
]

MIN_SECRET_BYTES: Final = 32
"""The shortest secret accepted: 256 bits, beyond any offline guessing."""

_SALT: Final = b"objectplaces"


def check_secret(secret: object, *, what: str = "secret") -> bytes:
    """``secret`` if it is bytes of at least ``MIN_SECRET_BYTES``.

    Raises:
        CredentialError: not bytes, or too short (the message says how to make one).
    """
    if not isinstance(secret, bytes):
        raise CredentialError(
            f"{what} must be bytes, got {type(secret).__name__} "
            "(in Python: secrets.token_bytes(32); a text secret: its .encode())"
        )
    if len(secret) < MIN_SECRET_BYTES:
        raise CredentialError(
            f"{what} is {len(secret)} bytes; at least {MIN_SECRET_BYTES} are needed "
            "(in Python: secrets.token_bytes(32); for a secret file: "
            "python -c 'import secrets; print(secrets.token_hex(32))')"
        )
    return secret


def check_private_file(path: Path, *, what: str) -> os.stat_result:
    """The status of ``path`` if it is a regular file no one but its owner can read.

    Raises:
        CredentialError: missing, not a file, or readable or writable by group or others.
    """
    try:
        status = path.stat()
    except OSError as exc:
        raise CredentialError(f"{what} {path}: cannot be read: {exc.strerror or exc}") from None
    if not stat.S_ISREG(status.st_mode):
        raise CredentialError(f"{what} {path}: not a regular file")
    mode = stat.S_IMODE(status.st_mode)
    if mode & 0o077:
        raise CredentialError(
            f"{what} {path}: mode {mode:04o} lets group or others read it; "
            f"only its owner may (chmod 600 {path})"
        )
    return status


def read_secret_file(path: Path) -> bytes:
    """The secret in ``path`` (one trailing newline dropped), after ``check_private_file``
    and ``check_secret``.

    Raises:
        CredentialError: the file or the secret in it cannot be used; the message says why.
    """
    check_private_file(path, what="secret file")
    try:
        secret = path.read_bytes()
    except OSError as exc:
        raise CredentialError(f"secret file {path}: cannot be read: {exc.strerror}") from None
    return check_secret(secret.rstrip(b"\r\n"), what=f"the secret in {path}")


def derive_key(secret: bytes, purpose: str, *, length: int = 32) -> bytes:
    """A key for one ``purpose`` (e.g. ``"mesh handshake"``), derived from ``secret``."""
    return HKDF(
        algorithm=hashes.SHA256(),
        length=length,
        salt=_SALT,
        info=purpose.encode(),
    ).derive(secret)
