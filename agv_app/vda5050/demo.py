"""``objectplaces demo --vda5050``: the broker the demo's vehicles use, and as whom.

- ``--vda5050`` alone: a throwaway fleet PKI in a private temporary folder and a
  mosquitto on 127.0.0.1 with its own certificate (:class:`~agv_app.vda5050.broker.
  LocalBroker`); the AGVs' and the monitor's certificates are issued from it, and one
  for a master control (role ``master``), whose paths the demo prints. With ``--pki
  DIR`` the broker and every client use DIR instead (DIR/broker.pem must name
  127.0.0.1); with ``--insecure``, a plain broker on loopback.
- ``--vda5050 mqtts://HOST:PORT --pki DIR``: your broker and your fleet PKI
  (DIR/agv-01.pem ..., and DIR/vda5050-monitor.pem of role ``control``); checked
  before the demo starts: reachable, trusted, and taking the monitor's certificate.
- ``--vda5050 mqtt://127.0.0.1:PORT --insecure``: a plain broker on loopback.

The broker and the throwaway PKI are stopped and removed when the demo ends: at a
clean exit, on SIGINT, and on SIGTERM (which otherwise ends Python at once, leaving
mosquitto running: the demo's uvicorn re-raises the SIGTERM it caught).
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from types import FrameType
from typing import Final

from agv_app.vda5050.broker import BROKER_ID, LocalBroker
from agv_app.vda5050.link import VdaCredentials, probe_broker
from agv_app.vda5050.monitor import MONITOR_ID, MONITOR_ROLES
from agv_app.vda5050.topics import parse_broker_url
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import Identity, TemporaryPki

__all__ = [
    "LOCAL",
    "MASTER_ID",
    "DemoBroker",
    "demo_vda5050",
    "unwind_on_sigterm",
]

LOCAL: Final = "local"
"""The ``--vda5050`` value (the flag alone) that starts a broker for the demo."""

MASTER_ID: Final = "master"
"""The master control's id in the demo's throwaway PKI."""

_HOST: Final = "127.0.0.1"


@dataclass(frozen=True)
class DemoBroker:
    """The broker the demo's vehicles use.

    Attributes:
        url: its address, ``mqtts://HOST:PORT`` (``mqtt://`` with ``--insecure``).
        credentials: where the vehicles' and the monitor's certificates come from.
        master: with the demo's own throwaway PKI, the identity a master control
            connects with (its certificate, key and the CA), else None.
    """

    url: str
    credentials: VdaCredentials
    master: Identity | None = None

    def describe(self) -> str:
        """What the demo prints about it."""
        text = f"VDA 5050 over {self.url}"
        if self.master is not None:
            text += (
                f"; a master control connects with the certificate {self.master.cert} "
                f"(key {self.master.key}, CA {self.master.ca})"
            )
        return text


@contextlib.contextmanager
def unwind_on_sigterm() -> Iterator[None]:
    """While the block runs (in the main thread), SIGTERM raises ``SystemExit(143)``
    where the program is, so every ``with`` on the way out runs; a second SIGTERM
    while unwinding is ignored."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum: int, _frame: FrameType | None) -> None:
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        raise SystemExit(128 + signum)

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def demo_vda5050(args: argparse.Namespace) -> Iterator[DemoBroker | None]:
    """The broker of ``objectplaces demo`` as its arguments say (see the module doc);
    the demo's own broker and PKI run as long as the block, SIGTERM included.

    Yields:
        The broker, or None without ``--vda5050``.

    Raises:
        ValueError: a malformed address.
        LocalProtocolError: the address and the credential options do not go together.
        CredentialError: a certificate or key is missing or unusable.
        BrokerError: your broker is unreachable, or refuses the monitor's certificate.
        FileNotFoundError: the demo's own broker without mosquitto installed.
        RuntimeError: mosquitto did not start.
    """
    value: str | None = getattr(args, "vda5050", None)
    if value is None:
        yield None
        return
    pki = getattr(args, "pki", None)
    insecure = bool(getattr(args, "insecure", False))
    if pki is not None and insecure:
        raise LocalProtocolError("give --pki or --insecure, not both")
    with contextlib.ExitStack() as stack:
        stack.enter_context(unwind_on_sigterm())
        if value != LOCAL:
            parse_broker_url(value)  # a malformed address is said first
            if pki is None and not insecure:
                raise LocalProtocolError(
                    f"--vda5050 {value} needs the fleet PKI of its clients (--pki DIR), or "
                    "--insecure for a plain mqtt:// broker on loopback"
                )
            credentials = VdaCredentials(pki, insecure=insecure)
            link = credentials.link(value, MONITOR_ID, roles=MONITOR_ROLES)
            probe_broker(link)
            yield DemoBroker(link.broker.url, credentials)
            return
        master = None
        if insecure:
            credentials = VdaCredentials(insecure=True)
            broker = LocalBroker(insecure=True)
        elif pki is not None:
            credentials = VdaCredentials(pki)
            broker = LocalBroker(Identity.from_pki(pki, BROKER_ID))
        else:
            throwaway = TemporaryPki(fleet="demo")
            stack.callback(throwaway.remove)
            # Issued before the broker starts, so its first access list has them.
            tls = throwaway.identity(BROKER_ID, role="router", addresses=(_HOST,))
            throwaway.identity(MONITOR_ID, role="control")
            master = throwaway.identity(MASTER_ID, role="master")
            credentials = VdaCredentials(throwaway)
            broker = LocalBroker(tls)
        address = stack.enter_context(broker)
        yield DemoBroker(address.url, credentials, master)
