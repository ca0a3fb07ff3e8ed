"""The one error of credentials: a certificate, key, secret or PKI folder that cannot be used."""

from __future__ import annotations

from objectplaces.core.errors import LocalProtocolError

__all__ = ["CredentialError"]


class CredentialError(LocalProtocolError):
    """A credential cannot be used; the message names its path and the reason.

    Raised when a node, router, bridge or dashboard starts, never later: an expired
    certificate, one signed by another CA, a key that does not match, a file that is
    missing, unreadable or readable by others, a secret too short.
    """
