"""How an MQTT client of the fleet reaches the broker, and as whom.

Secure by default: a client connects to ``mqtts://HOST:PORT`` with its certificate of
the fleet PKI (``objectplaces pki``), trusts the fleet CA alone, checks that the broker's
certificate names the host it dialled (its subject alternative names) and is not
revoked, and speaks TLS 1.3. The broker takes the certificate's id as the client's user
name and client id, so a vehicle's id, its serial number in the topics and its
certificate are one (``agv_app.vda5050.acl``). A plain ``mqtt://`` link is had only
when asked for by name (``insecure``), and only to a loopback address.

:func:`probe_broker` tells why a broker cannot be used, in words: unreachable, not
speaking TLS, a certificate we refuse, or ours refused (the client library only says
"timed out" then). It shakes hands and waits for the broker's verdict on its
certificate, and never sends a ``CONNECT``: it opens no session, so a probe never
takes over the client id of a running vehicle.
"""

from __future__ import annotations

import asyncio
import contextlib
import socket
import ssl
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Final

import aiomqtt

from agv_app.vda5050.topics import BrokerAddress, parse_broker_url
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import CredentialError, Identity, TemporaryPki, is_loopback

__all__ = [
    "BrokerError",
    "MqttLink",
    "VdaCredentials",
    "check_broker",
    "mqtt_link",
    "probe_broker",
]

_NODELAY: Final = (socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
_PINGREQ: Final = b"\xc0\x00"  # an MQTT PINGREQ: no session, the broker just hangs up
_PROBE_TIMEOUT_S: Final = 10.0
_TICKET_WAIT_S: Final = 3.0
_POLL_S: Final = 0.02
_ALERTS: Final = {
    "certificate revoked": "the certificate is revoked",
    "unknown ca": "the broker trusts another CA",
    "certificate required": "the broker wants a certificate",
    "certificate expired": "the certificate has expired",
}


class BrokerError(ConnectionError):
    """The broker cannot be used: unreachable, not TLS, not trusted, or it refused our
    certificate. The message names the broker and why."""


@dataclass(frozen=True)
class MqttLink:
    """Where one client connects and as whom.

    Attributes:
        broker: the broker's address (``tls``: ``mqtts``).
        identity: the client's certified identity (None: a plain link on loopback).
    """

    broker: BrokerAddress
    identity: Identity | None = None

    @property
    def client_id(self) -> str | None:
        """The MQTT client id the broker gives this client: its certificate's id."""
        return None if self.identity is None else self.identity.node_id

    def tls_context(self) -> ssl.SSLContext | None:
        """The client's TLS context (None on a plain link): its certificate, the fleet CA
        alone, the broker's host name or address checked, a revoked broker refused."""
        if self.identity is None:
            return None
        context = self.identity.client_context()
        context.check_hostname = True
        if self.identity.crl is not None:
            context.load_verify_locations(cafile=str(self.identity.crl))
            context.verify_flags |= ssl.VERIFY_CRL_CHECK_LEAF
        return context

    def client(
        self,
        *,
        identifier: str | None = None,
        will: aiomqtt.Will | None = None,
        keepalive: int = 60,
        tcp_nodelay: bool = True,
    ) -> aiomqtt.Client:
        """An ``aiomqtt`` client for this link (``identifier`` counts on plain links only:
        over TLS the broker names the client after its certificate)."""
        return aiomqtt.Client(
            self.broker.host,
            self.broker.port,
            identifier=identifier if self.identity is None else self.identity.node_id,
            will=will,
            keepalive=keepalive,
            tls_context=self.tls_context(),
            socket_options=[_NODELAY] if tcp_nodelay else [],
        )


def mqtt_link(
    broker: str | BrokerAddress,
    *,
    tls: Identity | None = None,
    insecure: bool = False,
    client_id: str | None = None,
    roles: tuple[str, ...] = (),
) -> MqttLink:
    """Check how a client asked to reach the broker, and say how it will.

    Args:
        broker: ``mqtts://HOST:PORT`` (with ``tls``) or ``mqtt://HOST:PORT`` (with
            ``insecure``, loopback only), or the parsed address.
        tls: the client's identity.
        insecure: a plain link, asked for by name.
        client_id: the id the client must have (a vehicle: its serial number).
        roles: the certificate roles this kind of client may have (empty: any).

    Raises:
        ValueError: a malformed address.
        LocalProtocolError: ``mqtts`` without an identity or with ``insecure``; ``mqtt``
            without ``insecure``, with an identity, or off loopback.
        CredentialError: the identity names another id, or a role not in ``roles``.
    """
    address = parse_broker_url(broker) if isinstance(broker, str) else broker
    if address.tls:
        if insecure:
            raise LocalProtocolError(
                f"{address.url} is TLS: give the certificate (--pki DIR), not --insecure "
                "(plain links are mqtt:// on loopback)"
            )
        if tls is None:
            raise LocalProtocolError(
                f"{address.url} needs a certificate of the fleet PKI: give --pki DIR "
                "(see `objectplaces pki`)"
            )
        if client_id is not None and tls.node_id != client_id:
            raise CredentialError(
                f"certificate {tls.cert} names {tls.node_id!r}, not {client_id!r}"
            )
        if roles and tls.role not in roles:
            raise CredentialError(
                f"certificate {tls.cert} is for role {tls.role!r}; this client needs "
                f"{' or '.join(roles)}"
            )
        return MqttLink(address, tls)
    if tls is not None or not insecure:
        raise LocalProtocolError(
            f"{address.url} is a plain link: use mqtts://{address.host}:PORT with --pki DIR, "
            "or --insecure for a plain link on loopback"
        )
    if not is_loopback(address.host):
        raise LocalProtocolError(
            f"plain links are allowed on loopback only, not to {address.host}: use "
            "mqtts:// with a certificate of the fleet PKI"
        )
    return MqttLink(address, None)


@dataclass(frozen=True)
class VdaCredentials:
    """Where a fleet's VDA 5050 clients get their certificates: a PKI folder (each id's
    ``ID.pem``, issued before), a throwaway PKI (issued on first ask), or none at all for
    plain links on loopback (``insecure``).

    Raises:
        LocalProtocolError: neither a PKI nor ``insecure``, or both.
    """

    pki: Path | TemporaryPki | None = None
    insecure: bool = False

    def __post_init__(self) -> None:
        if (self.pki is None) == (not self.insecure):
            raise LocalProtocolError(
                "VDA 5050 clients need a PKI (--pki DIR) or, for plain links on loopback, "
                "--insecure; not both"
            )

    @property
    def directory(self) -> Path | None:
        """The PKI folder (None: plain links)."""
        if self.pki is None:
            return None
        return self.pki.directory if isinstance(self.pki, TemporaryPki) else self.pki

    def identity(self, client_id: str, *, role: str) -> Identity | None:
        """The identity of ``client_id`` (a throwaway PKI issues it as ``role``).

        Raises:
            CredentialError: its certificate or key is missing or unusable.
        """
        if self.pki is None:
            return None
        if isinstance(self.pki, TemporaryPki):
            return self.pki.identity(client_id, role=role)
        return Identity.from_pki(self.pki, client_id)

    def link(
        self, broker: str | BrokerAddress, client_id: str, *, roles: tuple[str, ...]
    ) -> MqttLink:
        """The link of ``client_id`` to ``broker`` (see :func:`mqtt_link`); a throwaway
        PKI issues the certificate as ``roles[0]``."""
        tls = self.identity(client_id, role=roles[0])
        return mqtt_link(broker, tls=tls, insecure=self.insecure, client_id=client_id, roles=roles)


def _reason(exc: OSError) -> str:
    if isinstance(exc, ssl.SSLError) and exc.reason:
        return str(exc.reason).lower().replace("_", " ")
    return exc.strerror or str(exc) or type(exc).__name__


def _alert(exc: ssl.SSLError) -> str | None:
    """The TLS alert the broker sent, in words (None: no alert, the link just closed)."""
    reason = str(exc.reason or "")
    if "ALERT_" not in reason:
        return None
    said = reason.split("ALERT_", 1)[1].lower().replace("_", " ")
    return _ALERTS.get(said, said)


def probe_broker(link: MqttLink, *, timeout_s: float = _PROBE_TIMEOUT_S) -> None:
    """Connect to the broker as ``link`` says and return if it takes this client (blocks).

    Raises:
        BrokerError: unreachable; no TLS handshake; a broker certificate this client
            refuses; its own certificate refused. The message says which and why.
    """
    broker = link.broker
    try:
        raw = socket.create_connection((broker.host, broker.port), timeout=timeout_s)
    except OSError as exc:
        raise BrokerError(f"broker {broker.url} is unreachable: {_reason(exc)}") from None
    with raw:
        context = link.tls_context()
        if context is None:
            return  # plain: reachable is all there is to know without a session
        assert link.identity is not None
        ca = link.identity.ca
        try:
            tls = context.wrap_socket(raw, server_hostname=broker.host)
        except ssl.SSLCertVerificationError as exc:
            raise BrokerError(
                f"broker {broker.url}: its certificate is refused ({exc.verify_message}); it "
                f"must be signed by the fleet CA {ca}, issued for {broker.host} and not revoked"
            ) from None
        except ssl.SSLError as exc:
            alert = _alert(exc)
            if alert is not None:
                raise BrokerError(
                    f"broker {broker.url} refused the certificate {link.identity.cert} of "
                    f"{link.identity.node_id!r}: {alert}"
                ) from None
            raise BrokerError(
                f"broker {broker.url}: no TLS handshake ({_reason(exc)}); is it an mqtts listener?"
            ) from None
        except OSError as exc:
            raise BrokerError(
                f"broker {broker.url}: no TLS handshake ({_reason(exc)}); is it an mqtts listener?"
            ) from None
        with tls:
            try:
                alert = _verdict(tls, timeout_s=timeout_s)
            except TimeoutError:
                raise BrokerError(
                    f"broker {broker.url}: no answer within {timeout_s:g} s after the handshake"
                ) from None
        if alert is not None:
            raise BrokerError(
                f"broker {broker.url} refused the certificate {link.identity.cert} of "
                f"{link.identity.node_id!r}: {alert}"
            )


def _verdict(tls: ssl.SSLSocket, *, timeout_s: float) -> str | None:
    """The broker's verdict on our certificate: the alert it sent, in words, or None
    when it took it (raises TimeoutError after ``timeout_s`` without one).

    In TLS 1.3 the broker checks a client's certificate after the client's side of the
    handshake is done: it then sends session tickets (taken) or an alert (refused),
    and nothing else before an MQTT CONNECT. So wait for either. A broker that sends
    no tickets is sent a ``PINGREQ`` after a while instead: it hangs up on that if it
    took the certificate (an alert sent just as the ping arrives may then be lost).
    """
    deadline = time.monotonic() + timeout_s
    ticket_by = time.monotonic() + min(timeout_s, _TICKET_WAIT_S)
    tls.settimeout(_POLL_S)
    pinged = False
    while True:
        try:
            said = tls.recv(1)
        except TimeoutError:
            session = tls.session
            if session is not None and session.has_ticket:
                return None
            now = time.monotonic()
            if now > deadline:
                raise
            if now > ticket_by and not pinged:
                pinged = True
                with contextlib.suppress(OSError):
                    tls.sendall(_PINGREQ)
            continue
        except ssl.SSLError as exc:
            alert = _alert(exc)
            if alert is not None or pinged:
                return alert
        except OSError:
            if pinged:
                return None  # hung up on the ping: it took the certificate
        else:
            if said or pinged:
                return None  # it spoke, or hung up on the ping: it took the certificate
        return "it closed the connection after the handshake"


async def check_broker(link: MqttLink, *, timeout_s: float = _PROBE_TIMEOUT_S) -> None:
    """:func:`probe_broker` off the event loop.

    Raises:
        BrokerError: as :func:`probe_broker`.
    """
    await asyncio.to_thread(probe_broker, link, timeout_s=timeout_s)
