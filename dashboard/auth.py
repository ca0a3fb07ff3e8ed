"""Who may use the dashboard: a token per role, and the logins a token buys.

The dashboard asks every caller who it is, on loopback too: any page a browser shows,
from any site, can send requests to a loopback port, and any process of any user on the
machine can connect to one. Two roles: a ``viewer`` reads (every ``GET`` and the feed),
an ``operator`` reads and changes (every ``POST`` and ``DELETE``).

A caller proves its role with the role's token, either on every request
(``Authorization: Bearer <token>``, for scripts) or once, at ``POST /login``, which
trades it for a login cookie (for the page: a browser cannot put a header on a
WebSocket, and a token the page kept could be read by any script in it). The cookie
holds a random login key, never the token, and the server keeps only the key's SHA-256,
so neither a stolen cookie nor a look at the server's memory gives the token away; a
login ends after ``LOGIN_LIFETIME_S`` or when the server stops.

``Tokens`` come from ``Tokens.generate()`` (a new pair at every start) or from a token
file (``load_token_file``: created ``0600`` when missing, refused when others may read
it). Tokens are compared in constant time. Nothing here prints or logs a token; their
``repr`` hides them.
"""

from __future__ import annotations

import hashlib
import hmac
import re
import secrets
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Final, Literal

from objectplaces.security.errors import CredentialError
from objectplaces.security.pki import write_private
from objectplaces.security.secrets import check_private_file

__all__ = [
    "LOGIN_LIFETIME_S",
    "MAX_LOGINS",
    "MIN_TOKEN_CHARS",
    "ROLES",
    "Logins",
    "Role",
    "Tokens",
    "load_token_file",
]

Role = Literal["viewer", "operator"]
"""What a caller may do: a ``viewer`` reads, an ``operator`` reads and changes."""

ROLES: Final[tuple[Role, ...]] = ("viewer", "operator")

MIN_TOKEN_CHARS: Final = 32
"""The shortest token accepted: 32 URL-safe characters carry 192 bits."""

LOGIN_LIFETIME_S: Final = 12 * 3600.0
"""How long a login cookie lasts: a shift."""

MAX_LOGINS: Final = 1000
"""Most logins kept at once; the oldest ends first when a new one needs room."""

_TOKEN: Final = re.compile(rf"[A-Za-z0-9_-]{{{MIN_TOKEN_CHARS},256}}")
_FILE_HEADER: Final = (
    "# ObjectPlaces dashboard tokens: one line per role, 'ROLE TOKEN'. Only the owner may\n"
    "# read this file (mode 0600); anyone who reads a token has its role.\n"
)


@dataclass(frozen=True, slots=True)
class Tokens:
    """The operator's and the viewer's token.

    Raises:
        ValueError: a token shorter than ``MIN_TOKEN_CHARS``, with characters other than
            ``A-Z a-z 0-9 _ -``, or both the same.
    """

    operator: str = field(repr=False)
    viewer: str = field(repr=False)

    def __post_init__(self) -> None:
        for role in ROLES:
            if not _TOKEN.fullmatch(getattr(self, role)):
                raise ValueError(
                    f"the {role} token must be {MIN_TOKEN_CHARS} to 256 characters of "
                    "A-Z a-z 0-9 _ - (make one with: python -c 'import secrets; "
                    "print(secrets.token_urlsafe(32))')"
                )
        if hmac.compare_digest(self.operator, self.viewer):
            raise ValueError("the operator and the viewer token must differ")

    @classmethod
    def generate(cls) -> Tokens:
        """A new pair of random tokens (256 bits each)."""
        return cls(operator=secrets.token_urlsafe(32), viewer=secrets.token_urlsafe(32))

    def of(self, role: Role) -> str:
        """The token of ``role``."""
        return self.operator if role == "operator" else self.viewer

    def role_of(self, token: str) -> Role | None:
        """The role ``token`` proves, or None; constant time whatever it is."""
        given = token.encode("utf-8", "surrogateescape")
        operator = hmac.compare_digest(given, self.operator.encode())
        viewer = hmac.compare_digest(given, self.viewer.encode())
        return "operator" if operator else "viewer" if viewer else None

    def as_text(self) -> str:
        """The tokens as a token file holds them."""
        return f"{_FILE_HEADER}operator {self.operator}\nviewer {self.viewer}\n"


def load_token_file(path: Path) -> tuple[Tokens, bool]:
    """The tokens in ``path``, made and written first (mode ``0600``) if it is missing.

    The file holds one line per role, ``operator TOKEN`` and ``viewer TOKEN``; blank
    lines and lines starting with ``#`` are skipped.

    Returns:
        The tokens, and whether the file was created now.

    Raises:
        CredentialError: the file is readable or writable by others, not a regular file,
            unreadable, or does not hold one valid token per role; the message names the
            file and the reason.
    """
    if not path.exists() and not path.is_symlink():
        tokens = Tokens.generate()
        try:
            write_private(path, tokens.as_text().encode())
        except OSError as exc:
            raise CredentialError(
                f"token file {path}: cannot be created: {exc.strerror or exc}"
            ) from None
        return tokens, True
    check_private_file(path, what="token file")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise CredentialError(f"token file {path}: cannot be read: {exc}") from None
    found: dict[str, str] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        if len(words) != 2 or words[0] not in ROLES or words[0] in found:
            raise CredentialError(
                f"token file {path}, line {number}: expected 'operator TOKEN' or "
                f"'viewer TOKEN', once each, got {words[0][:20]!r}"
            )
        found[words[0]] = words[1]
    missing = [role for role in ROLES if role not in found]
    if missing:
        raise CredentialError(f"token file {path}: no {' and no '.join(missing)} token")
    try:
        return Tokens(operator=found["operator"], viewer=found["viewer"]), False
    except ValueError as exc:
        raise CredentialError(f"token file {path}: {exc}") from None


@dataclass(frozen=True, slots=True)
class _Login:
    role: Role
    until: float


class Logins:
    """The logins the page holds as cookies, by the SHA-256 of their random key.

    Args:
        lifetime_s: how long a login lasts.
        capacity: the most logins kept; the oldest ends when a new one needs room.
        clock: the time in seconds (monotonic).
    """

    def __init__(
        self,
        *,
        lifetime_s: float = LOGIN_LIFETIME_S,
        capacity: int = MAX_LOGINS,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.lifetime_s = lifetime_s
        self.capacity = capacity
        self._clock = clock
        self._logins: OrderedDict[bytes, _Login] = OrderedDict()

    def __len__(self) -> int:
        return len(self._logins)

    def open(self, role: Role) -> str:
        """A new login for ``role``; returns its key, the cookie's value."""
        key = secrets.token_urlsafe(32)
        while len(self._logins) >= self.capacity:
            self._logins.popitem(last=False)
        self._logins[_digest(key)] = _Login(role, self._clock() + self.lifetime_s)
        return key

    def role_of(self, key: str) -> Role | None:
        """The role of the login ``key`` opened, or None if there is none (any more)."""
        digest = _digest(key)
        login = self._logins.get(digest)
        if login is None:
            return None
        if self._clock() >= login.until:
            del self._logins[digest]
            return None
        return login.role

    def close(self, key: str) -> None:
        """End the login ``key`` opened, if it is open."""
        self._logins.pop(_digest(key), None)


def _digest(key: str) -> bytes:
    # Looked up by digest: how long a lookup takes says nothing about the keys held.
    return hashlib.sha256(key.encode("utf-8", "surrogateescape")).digest()
