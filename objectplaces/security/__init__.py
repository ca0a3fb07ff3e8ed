"""Identity and secrecy: the fleet PKI, members' certified identities, secrets.

- ``pki``: the fleet CA (``objectplaces pki``): make it, issue, revoke;
- ``identity``: a member's ``Identity`` (certificate, key, CA, revocation list) and the
  TLS contexts every transport builds from it; who a TLS peer proved to be;
- ``secrets``: secret files only their owner can read, 32 bytes at least, one key per
  purpose (HKDF).

docs/security.md has the threat model and how to run a fleet securely.
"""

from __future__ import annotations

from objectplaces.security.errors import CredentialError
from objectplaces.security.identity import Identity, PeerCertificate, Revocations, peer_of
from objectplaces.security.links import MEMBER_ROLES, LinkSecurity, is_loopback, link_security
from objectplaces.security.options import (
    SECRET_ENV,
    Credentials,
    add_credential_arguments,
    credentials_from_args,
)
from objectplaces.security.pki import ROLES, Issued, init_ca, issue, issued, revoke
from objectplaces.security.secrets import (
    MIN_SECRET_BYTES,
    check_private_file,
    check_secret,
    derive_key,
    read_secret_file,
)
from objectplaces.security.temporary import TemporaryPki

__all__ = [
    "MEMBER_ROLES",
    "MIN_SECRET_BYTES",
    "ROLES",
    "SECRET_ENV",
    "CredentialError",
    "Credentials",
    "Identity",
    "Issued",
    "LinkSecurity",
    "PeerCertificate",
    "Revocations",
    "TemporaryPki",
    "add_credential_arguments",
    "check_private_file",
    "check_secret",
    "credentials_from_args",
    "derive_key",
    "init_ca",
    "is_loopback",
    "issue",
    "issued",
    "link_security",
    "peer_of",
    "read_secret_file",
    "revoke",
]
