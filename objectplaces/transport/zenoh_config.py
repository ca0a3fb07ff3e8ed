"""A node's Zenoh configuration: mode, endpoints, lease, and how its links are protected.

Links are mutual TLS by default (``tls/`` endpoints): every session presents its
certificate of the fleet CA and accepts only peers that present one too
(``enable_mtls``); a client also checks that the router it reached is named for that
address in the router's certificate (``verify_name_on_connect``). Who a peer is, is its
certificate's common name, and access control gives each member its own keys
(``zenoh_acl``). Zenoh is told to use ``tls`` links and nothing else.

Plain ``tcp/`` links are for loopback only (``insecure=True``): every node then derives
one user name and password from the fleet secret (HKDF, one key per purpose; the secret
itself is in no file and no configuration), proves them with Zenoh's user/password
authentication on every link it opens, and accepts a link only from a session that
proves the same pair. The pair sits in a dictionary file written 0600 into a private
temporary directory and removed when the session closes.

Multicast scouting is off: a node reaches only the endpoints it is given, and the peers
its neighbours tell it about (gossip), so nodes that know only a chain of endpoints
still meet. Zenoh peers do not forward for one another (Zenoh 1.10: peers of one region
talk peer to peer; only routers route), so every pair of peers needs a link of its own,
and the fleet forms when each has one. Of each pair only the peer with the greater
Zenoh id dials (``greater-zid``), and gossip goes to the next hop only: with both
dialing and gossip passed on over every hop, 50 peers on 2 cores were still short of
links after 110 s (each link change gossiped to all, links dialed twice and refused),
and formed in about 20 s without (``PEER_SCOUTING``).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import tempfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from objectplaces.core import codec
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security.identity import Identity
from objectplaces.security.secrets import derive_key
from objectplaces.transport.zenoh_alive import TOKEN_GRACE
from objectplaces.transport.zenoh_lib import zenoh

__all__ = [
    "PEER_SCOUTING",
    "Credentials",
    "CredentialsFile",
    "ZenohOptions",
    "ZenohSecurity",
    "check_protocol",
    "derive_credentials",
    "endpoint_host",
    "fleet_of",
    "resolve_ports",
    "zenoh_config",
]

Mode = Literal["peer", "client", "router"]
_MODES = ("peer", "client", "router")


@dataclass(frozen=True, slots=True)
class ZenohOptions:
    """Where and how a node joins Zenoh; durations in seconds.

    Attributes:
        mode: ``peer`` (links to other peers, found through the endpoints and gossip),
            ``client`` (one link to a router) or ``router``.
        listen: endpoints to listen on, e.g. ``tcp/127.0.0.1:7447`` (port 0 picks one).
        connect: endpoints to connect to (peers or routers).
        fleet: the fleet's name; nodes of other fleets share no key.
        lease: a silent peer's links are dropped after this long, and with them its
            liveliness token. Zenoh's default, 10 s: a shorter lease drops the links of
            processes merely starved of CPU (30 peers on 2 busy cores with 2 s: links
            lapsed and came back for ever, and the fleet never formed). A frozen node
            leaves its groups sooner by the machine's ``failure_timeout``.
        token_grace: a node whose liveliness token goes stays in its groups this long,
            and leaves them only if its token is not back by then (Zenoh withdraws and
            redeclares tokens as routes change); 0: it leaves at once.
        max_frame: largest frame accepted, in bytes.
        poll_interval: seconds between two polls of the data subscribers (None: data is
            handed on by callback at once). Polling costs frames up to this much delay
            and saves two thread wake-ups per frame (``zenoh_inbox``).
        extra: further Zenoh configuration (json5 paths and values), applied last.
    """

    mode: Mode = "peer"
    listen: tuple[str, ...] = ("tcp/127.0.0.1:0",)
    connect: tuple[str, ...] = ()
    fleet: str = "default"
    lease: float = 10.0
    token_grace: float = TOKEN_GRACE
    max_frame: int = codec.DEFAULT_MAX_FRAME
    poll_interval: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.mode not in _MODES:
            raise LocalProtocolError(f"mode must be one of {_MODES}, got {self.mode!r}")
        for name in ("listen", "connect"):
            value = getattr(self, name)
            if isinstance(value, str) or not all(_is_endpoint(e) for e in value):
                raise LocalProtocolError(
                    f"{name} must be a list of endpoints like tcp/127.0.0.1:7447, got {value!r}"
                )
        if not self.lease >= 0.1:
            raise LocalProtocolError(f"lease must be >= 0.1 s, got {self.lease!r}")
        if not 0 <= self.token_grace <= self.lease:
            raise LocalProtocolError(
                f"token_grace must be in [0, lease] s, got {self.token_grace!r}"
            )
        if self.max_frame < 64:
            raise LocalProtocolError(f"max_frame too small: {self.max_frame!r}")
        if self.poll_interval is not None and not 0 < self.poll_interval <= 1.0:
            raise LocalProtocolError(
                f"poll_interval must be None or in (0, 1] s, got {self.poll_interval!r}"
            )


PEER_SCOUTING: dict[str, Any] = {
    "scouting/gossip/multihop": False,
    "scouting/gossip/autoconnect_strategy": {
        "peer": {"to_router": "always", "to_peer": "greater-zid"}
    },
}
"""How peers find each other: gossip to the next hop only, and one dialer per pair.
Links up one by one bring their peers' news a hop further, so a chain of endpoints still
becomes a full mesh; every peer reachable from every other (127.0.0.1 here) makes
``greater-zid`` safe."""


def _is_endpoint(endpoint: object) -> bool:
    if not isinstance(endpoint, str):
        return False
    proto, sep, address = endpoint.partition("/")
    return bool(sep and proto in ("tcp", "udp", "tls", "quic") and ":" in address)


@dataclass(frozen=True, slots=True)
class Credentials:
    """The user name and password every node of one fleet derives from its secret."""

    user: str
    password: str


def derive_credentials(secret: bytes, fleet: str) -> Credentials:
    """The usrpwd pair of ``fleet`` under ``secret`` (never the secret itself): one key
    for the user name and another for the password (``derive_key``)."""
    if not isinstance(secret, bytes) or not secret:
        raise LocalProtocolError("secret must be non-empty bytes")
    user = derive_key(secret, f"zenoh user name {fleet}", length=8)
    password = derive_key(secret, f"zenoh password {fleet}")
    return Credentials(user="op-" + user.hex(), password=password.hex())


class CredentialsFile:
    """The dictionary file of accepted credentials, in a private temporary directory.

    ``remove()`` deletes the file and its directory (again is fine).
    """

    def __init__(self, credentials: Credentials) -> None:
        self._dir = Path(tempfile.mkdtemp(prefix="objectplaces-zenoh-"))
        os.chmod(self._dir, 0o700)
        self.path = self._dir / "usrpwd"
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        with os.fdopen(fd, "w") as file:
            file.write(f"{credentials.user}:{credentials.password}\n")

    def remove(self) -> None:
        """Delete the file and its directory."""
        shutil.rmtree(self._dir, ignore_errors=True)


@dataclass(frozen=True)
class ZenohSecurity:
    """How one session's links are protected, and what it lets through.

    Attributes:
        tls: mutual TLS with this identity (None: plain ``tcp/`` links).
        verify_name: with ``tls``, check that a router reached names the address dialed
            (clients and routers; peers' certificates name no address).
        usrpwd: user/password authentication with these credentials and dictionary.
        access_control: Zenoh's ``access_control`` section (None: none).
    """

    tls: Identity | None = None
    verify_name: bool = True
    usrpwd: tuple[Credentials, Path] | None = None
    access_control: dict[str, Any] | None = None

    @property
    def protocol(self) -> str:
        """The one link protocol of these links: ``tls`` or ``tcp``."""
        return "tcp" if self.tls is None else "tls"


def zenoh_config(options: ZenohOptions, security: ZenohSecurity) -> zenoh.Config:
    """The ``zenoh.Config`` of a session with these options and this protection."""
    config = zenoh.Config()
    lease_ms = max(int(options.lease * 1000), 100)
    settings: dict[str, Any] = {
        "mode": options.mode,
        "listen/endpoints": list(options.listen) if options.mode != "client" else [],
        "connect/endpoints": list(options.connect),
        "scouting/multicast/enabled": False,
        **PEER_SCOUTING,
        "transport/link/tx/lease": lease_ms,
        "transport/link/protocols": [security.protocol],
    }
    tls = security.tls
    if tls is not None:
        settings["transport/link/tls"] = {
            "root_ca_certificate": str(tls.ca),
            "listen_certificate": str(tls.cert),
            "listen_private_key": str(tls.key),
            "connect_certificate": str(tls.cert),
            "connect_private_key": str(tls.key),
            "enable_mtls": True,
            "verify_name_on_connect": security.verify_name,
            "close_link_on_expiration": True,
        }
    if security.usrpwd is not None:
        credentials, dictionary = security.usrpwd
        settings["transport/auth/usrpwd"] = {
            "user": credentials.user,
            "password": credentials.password,
            "dictionary_file": str(dictionary),
        }
    if security.access_control is not None:
        settings["access_control"] = security.access_control
    settings.update(options.extra)
    for key, value in settings.items():
        config.insert_json5(key, json.dumps(value))
    return config


def fleet_of(tls: Identity | None, fleet: str | None) -> str:
    """The fleet a session joins: ``fleet`` (``default`` if None), or with ``tls`` the
    certificate's, which ``fleet`` must name if given.

    Raises:
        LocalProtocolError: ``fleet`` is not the certificate's.
    """
    if tls is None:
        return "default" if fleet is None else fleet
    if fleet is not None and fleet != tls.fleet:
        raise LocalProtocolError(f"certificate {tls.cert} is of fleet {tls.fleet!r}, not {fleet!r}")
    return tls.fleet


def endpoint_host(endpoint: str) -> str:
    """The host of an endpoint such as ``tls/10.0.0.1:7447`` (``10.0.0.1``)."""
    address = endpoint.partition("/")[2].split("#", 1)[0].split("?", 1)[0]
    return address.rpartition(":")[0]


def check_protocol(endpoints: Iterable[str], protocol: str) -> None:
    """Refuse an endpoint of another protocol than the links': ``tls`` with a
    certificate, ``tcp`` for plain links.

    Raises:
        LocalProtocolError: naming the first endpoint that is not ``protocol/...``.
    """
    for endpoint in endpoints:
        if endpoint.partition("/")[0] != protocol:
            how = "mutual TLS" if protocol == "tls" else "plain links (insecure=True)"
            raise LocalProtocolError(
                f"with {how} every endpoint is {protocol}/HOST:PORT, got {endpoint!r}"
            )


def resolve_ports(endpoints: Sequence[str]) -> tuple[str, ...]:
    """``endpoints`` with every TCP or TLS port 0 replaced by a port free now.

    Zenoh does not report the port it picked, so we pick one and tell it; another
    process could take it in between (then opening fails with ``OSError``).
    """
    resolved = []
    for endpoint in endpoints:
        proto, _, address = endpoint.partition("/")
        host, _, port = address.rpartition(":")
        if proto in ("tcp", "tls") and port == "0":
            with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
                probe.bind((host.strip("[]"), 0))
                endpoint = f"{proto}/{host}:{probe.getsockname()[1]}"
        resolved.append(endpoint)
    return tuple(resolved)
