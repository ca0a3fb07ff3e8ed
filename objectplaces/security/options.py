"""The credential options every command that joins a fleet takes, read the same way.

``--pki D`` (mutual TLS with ``D/ID.pem``), or ``--insecure`` with ``--secret-file F``
(or the ``OBJECTPLACES_SECRET`` environment variable) for plain links on loopback. A
credential that cannot be used is a ``CredentialError`` naming its path and the
reason; the commands print it and exit with status 2.
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from objectplaces.security.errors import CredentialError
from objectplaces.security.identity import Identity
from objectplaces.security.secrets import check_secret, read_secret_file

__all__ = ["SECRET_ENV", "Credentials", "add_credential_arguments", "credentials_from_args"]

SECRET_ENV: Final = "OBJECTPLACES_SECRET"
"""Environment variable holding the secret of plain links when ``--secret-file`` is not given."""


@dataclass(frozen=True)
class Credentials:
    """How a process joins: its identity (mutual TLS), or plain links and a secret."""

    tls: Identity | None
    secret: bytes | None
    insecure: bool

    def as_kwargs(self) -> dict[str, Any]:
        """The ``tls``, ``secret`` and ``insecure`` arguments of ``start_node`` and the like."""
        return {"tls": self.tls, "secret": self.secret, "insecure": self.insecure}

    def as_arguments(self, pki: Path | None = None, secret_file: Path | None = None) -> list[str]:
        """The same credentials as command-line arguments for a child process: ``--pki``
        (``pki``, the folder the identity came from) or ``--insecure --secret-file``."""
        if self.tls is not None:
            return ["--pki", str(pki if pki is not None else self.tls.ca.parent)]
        if secret_file is None:
            raise CredentialError("a child with plain links needs the secret in a file")
        return ["--insecure", "--secret-file", str(secret_file)]


def add_credential_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--pki``, ``--insecure`` and ``--secret-file`` to ``parser``."""
    group = parser.add_argument_group("credentials (mutual TLS by default)")
    group.add_argument(
        "--pki",
        type=Path,
        metavar="DIR",
        help="the fleet PKI folder (objectplaces pki): mutual TLS with DIR/ID.pem and "
        "DIR/ID.key, trusting DIR/ca.pem, refusing what DIR/crl.pem revokes",
    )
    group.add_argument(
        "--insecure",
        action="store_true",
        help=f"plain links instead, on loopback only, proven by a secret (--secret-file "
        f"or env {SECRET_ENV}, 32 bytes or more)",
    )
    group.add_argument(
        "--secret-file",
        type=Path,
        metavar="FILE",
        help="file holding the secret of plain links (mode 0600; with --insecure)",
    )


def credentials_from_args(args: argparse.Namespace, node_id: str) -> Credentials:
    """The credentials ``args`` name for ``node_id``.

    Raises:
        CredentialError: neither ``--pki`` nor ``--insecure``, or both; a file or a
            secret that cannot be used (named, with the reason).
    """
    pki: Path | None = args.pki
    if pki is not None and args.insecure:
        raise CredentialError("give --pki or --insecure, not both")
    if pki is not None:
        return Credentials(Identity.from_pki(pki, node_id), None, insecure=False)
    if not args.insecure:
        raise CredentialError(
            "give --pki DIR (mutual TLS; make DIR with `objectplaces pki init`), or "
            "--insecure and a secret for plain links on loopback"
        )
    if args.secret_file is not None:
        return Credentials(None, read_secret_file(args.secret_file), insecure=True)
    value = os.environ.get(SECRET_ENV, "")
    if not value:
        raise CredentialError(f"--insecure needs --secret-file FILE or {SECRET_ENV} set")
    return Credentials(None, check_secret(value.encode(), what=SECRET_ENV), insecure=True)
