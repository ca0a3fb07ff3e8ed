"""How a served dashboard is reached: its tokens, TLS, host names, and the login URLs.

The options of every command that serves the dashboard (``objectplaces demo``), read the
same way. Loopback is the default, and TLS is required anywhere else; tokens never
travel on a command line, where ``ps`` shows them to every user of the machine: they
are made at start, or kept in a token file only their owner can read
(``dashboard.auth.load_token_file``).
"""

from __future__ import annotations

import argparse
import ipaddress
import os
import re
import socket
import ssl
from dataclasses import dataclass
from pathlib import Path
from typing import Final

from dashboard.auth import Role, Tokens, load_token_file
from dashboard.guard import LOOPBACK_HOSTS
from objectplaces.security import CredentialError, Identity, check_private_file, is_loopback

__all__ = [
    "CONTROL_ID",
    "TOKEN_ENV",
    "Listening",
    "add_listen_arguments",
    "listening_from_args",
    "login_url",
]

CONTROL_ID: Final = "control"
"""The member whose certificate the dashboard serves with ``--pki``."""

TOKEN_ENV: Final = "OBJECTPLACES_TOKEN"
"""An environment variable that is refused: tokens come from ``--token-file``."""

_WILDCARDS: Final = ("0.0.0.0", "::", "")
_HOST_NAME: Final = re.compile(r"[A-Za-z0-9]([A-Za-z0-9.-]{0,252})")


@dataclass(frozen=True)
class Listening:
    """Where a dashboard listens and how it is reached.

    Attributes:
        host: the address it listens on.
        port: the port.
        tokens: the operator's and the viewer's token.
        hosts: the names clients reach it by, besides the loopback ones (``Host``).
        tls: the certificate and key files it serves TLS with, or None (loopback only).
        token_file: the token file, if one is used; ``created``: made at this start.
    """

    host: str
    port: int
    tokens: Tokens
    hosts: tuple[str, ...] = ()
    tls: tuple[Path, Path] | None = None
    token_file: Path | None = None
    created: bool = False


def add_listen_arguments(parser: argparse.ArgumentParser, *, pki: bool = True) -> None:
    """Add ``--host``, ``--token-file``, ``--tls-cert``, ``--tls-key``, ``--allowed-host``
    and, unless the command has it already (``pki=False``), ``--pki``."""
    group = parser.add_argument_group("access (a token always; TLS off loopback)")
    group.add_argument(
        "--host",
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1); any other than loopback needs TLS",
    )
    group.add_argument(
        "--token-file",
        type=Path,
        metavar="FILE",
        help="the operator's and the viewer's token, lines 'operator TOKEN' and "
        "'viewer TOKEN' (mode 0600; made with new tokens if missing); default: new "
        "tokens at every start",
    )
    group.add_argument("--tls-cert", type=Path, metavar="FILE", help="serve TLS: certificate")
    group.add_argument("--tls-key", type=Path, metavar="FILE", help="... and its key (mode 0600)")
    if pki:
        group.add_argument(
            "--pki",
            type=Path,
            metavar="DIR",
            help=f"serve TLS with the fleet PKI's certificate of {CONTROL_ID!r} "
            f"(DIR/{CONTROL_ID}.pem, DIR/{CONTROL_ID}.key)",
        )
    group.add_argument(
        "--allowed-host",
        action="append",
        default=[],
        metavar="NAME",
        help="a name or address clients reach the dashboard by (again for more); the "
        "loopback ones, the --host address and, on 0.0.0.0 or ::, this machine's name "
        "are allowed anyway; requests naming any other host are refused",
    )
    # Refused with a pointer to --token-file, rather than left unknown.
    group.add_argument("--token", help=argparse.SUPPRESS)


def listening_from_args(args: argparse.Namespace, port: int) -> Listening:
    """What ``args`` ask for.

    Raises:
        CredentialError: a token on the command line or in the environment; TLS files,
            a PKI or a token file that cannot be used; a host off loopback without TLS.
            The message names the option or file and what to do.
    """
    if args.token is not None:
        raise CredentialError(
            "--token puts the token on the command line, where `ps` shows it to every "
            "user: give --token-file FILE instead (made with new tokens if missing)"
        )
    if os.environ.get(TOKEN_ENV):
        raise CredentialError(f"tokens come from --token-file FILE, not {TOKEN_ENV}: unset it")
    host: str = args.host
    tls = _tls_files(args)
    if tls is None and not is_loopback(host):
        raise CredentialError(
            f"--host {host} lets other machines in, and a token over plain HTTP can be "
            "read on the way: serve TLS there (--tls-cert FILE --tls-key FILE, or --pki DIR)"
        )
    for name in args.allowed_host:
        if not _HOST_NAME.fullmatch(name) and not _is_address(name.strip("[]")):
            raise CredentialError(f"--allowed-host: a host name or address, got {name!r}")
    token_file: Path | None = args.token_file
    created = False
    if token_file is None:
        tokens = Tokens.generate()
    else:
        tokens, created = load_token_file(token_file)
    return Listening(
        host=host,
        port=port,
        tokens=tokens,
        hosts=_hosts(host, args.allowed_host),
        tls=tls,
        token_file=token_file,
        created=created,
    )


def login_url(listening: Listening, role: Role = "operator") -> str:
    """The URL that logs a browser in with ``role``'s token (in the fragment, which a
    browser never sends on; the login page takes it out of the address bar)."""
    scheme = "https" if listening.tls else "http"
    host = listening.host
    if host in _WILDCARDS:
        host = listening.hosts[0] if listening.hosts else "127.0.0.1"
    return f"{scheme}://{_bracketed(host)}:{listening.port}/login#token={listening.tokens.of(role)}"


def _tls_files(args: argparse.Namespace) -> tuple[Path, Path] | None:
    cert: Path | None = args.tls_cert
    key: Path | None = args.tls_key
    pki: Path | None = getattr(args, "pki", None)
    if pki is not None and (cert is not None or key is not None):
        raise CredentialError("give --pki DIR or --tls-cert and --tls-key, not both")
    if pki is not None:
        identity = Identity.from_pki(pki, CONTROL_ID)
        return identity.cert, identity.key
    if cert is None and key is None:
        return None
    if cert is None or key is None:
        raise CredentialError("--tls-cert FILE and --tls-key FILE go together")
    check_private_file(key, what="TLS key")
    try:
        ssl.create_default_context(ssl.Purpose.CLIENT_AUTH).load_cert_chain(cert, key)
    except (OSError, ssl.SSLError) as exc:
        raise CredentialError(
            f"TLS certificate {cert} with key {key} cannot be used: {exc.strerror or exc}"
        ) from None
    return cert, key


def _hosts(host: str, allowed: list[str]) -> tuple[str, ...]:
    names: list[str] = [_bracketed(name.lower()) for name in allowed]
    if host in _WILDCARDS:
        names += [socket.gethostname().lower(), socket.getfqdn().lower()]
    else:
        names.append(_bracketed(host.lower()))
    return tuple(dict.fromkeys(n for n in names if n and n not in LOOPBACK_HOSTS))


def _is_address(text: str) -> bool:
    try:
        ipaddress.ip_address(text)
    except ValueError:
        return False
    return True


def _bracketed(host: str) -> str:
    host = host.strip("[]")
    return f"[{host}]" if _is_address(host) and ":" in host else host
