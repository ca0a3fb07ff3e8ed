"""How a node's links are protected, decided once when it starts.

Secure by default: a node joins with its certified ``Identity`` (mutual TLS, its id the
certificate's). A plain link is had only when asked for by name (``insecure=True``),
with a secret of 32 bytes or more, and only where every address is a loopback one: a
plain link off loopback is refused, whatever else is given.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final

from cryptography.hazmat.primitives import serialization
from cryptography.x509 import load_pem_x509_certificate

from objectplaces.core.errors import LocalProtocolError
from objectplaces.security.errors import CredentialError
from objectplaces.security.identity import Identity
from objectplaces.security.secrets import check_secret, derive_key

__all__ = ["MEMBER_ROLES", "LinkSecurity", "is_loopback", "link_security"]

MEMBER_ROLES: Final = ("node", "agv", "control")
"""Roles whose certificate makes a node a member (routers route, masters command over
VDA 5050; neither joins as a node)."""


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``, brackets allowed) is a loopback one."""
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


@dataclass(frozen=True)
class LinkSecurity:
    """How one node's links are protected.

    Attributes:
        identity: the node's certified identity (None: plain links on loopback).
        handshake_key: the key the mesh handshake proves (from the secret, or the CA).
    """

    identity: Identity | None
    handshake_key: bytes

    @property
    def tls(self) -> bool:
        """Whether links run mutual TLS."""
        return self.identity is not None


def link_security(
    node_id: str,
    *,
    tls: Identity | None,
    secret: bytes | None,
    insecure: bool,
    hosts: Iterable[str],
    roles: tuple[str, ...] = MEMBER_ROLES,
) -> LinkSecurity:
    """Check how a node asked to be linked, and say how it will be.

    Args:
        node_id: the node's id.
        tls: its identity (mutual TLS).
        secret: with ``insecure``, the secret every plain link proves (32 bytes at least);
            with ``tls``, an optional second factor of the handshake.
        insecure: plain links, asked for by name.
        hosts: every host the node listens on or dials.
        roles: the certificate roles allowed for this kind of node.

    Raises:
        LocalProtocolError: neither ``tls`` nor ``insecure``, or both; a plain link off
            loopback.
        CredentialError: the identity names another id or role; a secret too short.
    """
    if tls is None and not insecure:
        raise LocalProtocolError(
            "links are mutual TLS by default: give tls=Identity.from_pki(DIR, "
            f"{node_id!r}) (see `objectplaces pki`), or insecure=True and a secret for "
            "plain links on loopback"
        )
    if tls is not None and insecure:
        raise LocalProtocolError("give tls= or insecure=True, not both")
    if tls is None:
        away = sorted({h for h in hosts if not is_loopback(h)})
        if away:
            raise LocalProtocolError(
                f"plain links are allowed on loopback only, not on {', '.join(away)}: "
                "use tls= with a certificate of the fleet PKI"
            )
        if secret is None:
            raise LocalProtocolError("insecure=True needs a secret (32 bytes or more)")
        return LinkSecurity(None, derive_key(check_secret(secret), "mesh handshake"))
    if tls.node_id != node_id:
        raise CredentialError(f"certificate {tls.cert} names {tls.node_id!r}, not {node_id!r}")
    if tls.role not in roles:
        raise CredentialError(
            f"certificate {tls.cert} is for role {tls.role!r}; this needs one of {', '.join(roles)}"
        )
    if secret is not None:
        key = derive_key(check_secret(secret), "mesh handshake")
    else:  # TLS proves who is who; the handshake's proof then binds the link to the fleet
        ca = load_pem_x509_certificate(tls.ca.read_bytes())
        key = derive_key(ca.public_bytes(serialization.Encoding.DER), "mesh handshake")
    return LinkSecurity(tls, key)
