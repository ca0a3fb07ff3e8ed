"""The fleet's roster as its PKI folder says now, re-read when it changes.

A router (and a peer) gives each member its keys by certificate name, from the
certificates the CA issued (``D/members.json``) less those the revocation list
(``D/crl.pem``) names; a node drops what a revoked id sends. Both files are public and
replaced whole by ``objectplaces pki`` (never seen half written); a look is two ``stat``
calls, and a file is read only when it changed. A file that cannot be read now keeps
what was read before: the next look reads it.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Final

from objectplaces.security.errors import CredentialError
from objectplaces.security.identity import Identity
from objectplaces.security.pki import MEMBERS_FILE, Issued, issued
from objectplaces.transport.zenoh_acl import Roster, roster_of

__all__ = ["ROSTER_CHECK", "RosterWatch"]

log = logging.getLogger("objectplaces.zenoh")

ROSTER_CHECK: Final = 1.0
"""Seconds between two looks at ``members.json`` and the revocation list."""


class RosterWatch:
    """The roster of the fleet of ``identity``, from the folder of its CA certificate.

    Args:
        identity: a member's or router's identity (``Identity.from_pki``); its CA's
            folder holds ``members.json``, and its revocation list is re-read.

    Raises:
        CredentialError: the folder holds no ``members.json``, or it cannot be read.
    """

    def __init__(self, identity: Identity) -> None:
        self._identity = identity
        self._folder = identity.ca.parent
        self._path = self._folder / MEMBERS_FILE
        self._stamp: tuple[int, int, int] | None = None
        self._issued: list[Issued] = []
        if not self._path.is_file():
            raise CredentialError(
                f"{self._path}: missing; routers and peers read it to give each member its keys"
            )
        self._read(strict=True)
        self.roster = self._roster()

    @property
    def path(self) -> Path:
        """The ``members.json`` watched."""
        return self._path

    def poll(self) -> Roster | None:
        """Re-read whatever changed since the last look.

        Returns:
            The new roster if it differs from the last one, else None.
        """
        self._identity.refresh_revocations()
        self._read(strict=False)
        roster = self._roster()
        if roster == self.roster:
            return None
        self.roster = roster
        return roster

    def _read(self, *, strict: bool) -> None:
        try:
            status = self._path.stat()
            stamp = (status.st_mtime_ns, status.st_size, status.st_ino)
            if stamp == self._stamp:
                return
            entries = issued(self._folder)
        except (OSError, CredentialError) as exc:
            if strict:
                raise CredentialError(f"{self._path}: cannot be read: {exc}") from None
            log.warning("%s: cannot be read now, the roster stays as it was: %s", self._path, exc)
            return
        self._stamp = stamp
        self._issued = entries

    def _roster(self) -> Roster:
        revocations = self._identity.revocations
        serials = revocations.serials if revocations is not None else frozenset()
        return roster_of(self._issued, serials)
