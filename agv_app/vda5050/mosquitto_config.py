"""mosquitto's configuration as the project writes it, and where mosquitto is installed.

:func:`broker_config` is the text of ``mosquitto.conf`` for one listener: plain with
anonymous clients, or TLS 1.3 with a certificate of the fleet CA required from every
client, the certificate's id as user name and client id, and the access list
(:mod:`agv_app.vda5050.acl`). :func:`names_address` checks that the broker's
certificate names the address it listens on. Starting, reloading and stopping the
process is :class:`agv_app.vda5050.broker.LocalBroker`'s job.
"""

from __future__ import annotations

import ipaddress
import os
import shutil
from pathlib import Path
from typing import Final

from cryptography import x509

from objectplaces.security import Identity

__all__ = ["broker_config", "find_mosquitto", "names_address"]

_CANDIDATES: Final = (
    "/usr/sbin/mosquitto",
    "/usr/local/sbin/mosquitto",
    "/opt/homebrew/sbin/mosquitto",
)


def find_mosquitto() -> str | None:
    """The path of the mosquitto executable, or None if it is not installed."""
    found = shutil.which("mosquitto")
    if found:
        return found
    return next((c for c in _CANDIDATES if Path(c).is_file()), None)


def names_address(identity: Identity, host: str) -> bool:
    """Whether the identity's certificate names ``host`` among its alternative names."""
    cert = x509.load_pem_x509_certificate(identity.cert.read_bytes())
    try:
        names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    except x509.ExtensionNotFound:
        return False
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        return host.lower() in (n.lower() for n in names.get_values_for_type(x509.DNSName))
    return address in names.get_values_for_type(x509.IPAddress)


def broker_config(
    *,
    host: str,
    port: int,
    tls: Identity | None,
    acl_file: Path | None,
    tcp_nodelay: bool = True,
) -> str:
    """The text of mosquitto's configuration (see :mod:`agv_app.vda5050.broker`).

    Args:
        host: the listener's address.
        port: its port.
        tls: the broker's identity (None: a plain listener, anonymous clients).
        acl_file: the access list (with ``tls``).
        tcp_nodelay: ``set_tcp_nodelay`` (off only to measure what it saves).
    """
    lines = [
        "per_listener_settings false",
        "persistence false",
        f"set_tcp_nodelay {'true' if tcp_nodelay else 'false'}",
        "max_queued_messages 10000",
    ]
    if os.geteuid() == 0:
        # As root, mosquitto drops to the user "mosquitto", who cannot read the PKI
        # folder (0700). Stay the user who started it, as for anyone else.
        lines.append("user root")
    if tls is None:
        lines += ["allow_anonymous true", f"listener {port} {host}"]
        return "\n".join(lines) + "\n"
    assert acl_file is not None
    lines += [
        "allow_anonymous false",
        f"acl_file {acl_file}",
        f"listener {port} {host}",
        f"cafile {tls.ca}",
        f"certfile {tls.cert}",
        f"keyfile {tls.key}",
        *([] if tls.crl is None else [f"crlfile {tls.crl}"]),
        "require_certificate true",
        "use_identity_as_username true",
        "use_username_as_clientid true",
        "tls_version tlsv1.3",
    ]
    return "\n".join(lines) + "\n"
