"""A mosquitto broker the project configures: mutual TLS and an access list per identity.

:class:`LocalBroker` writes mosquitto's configuration and starts it, waits (bounded)
until it accepts connections, and stops it again, removing its files. With the
broker's certified identity (``objectplaces pki``; role ``router``, issued for the
address it listens on) it has one TLS 1.3 listener that:

- requires a certificate of the fleet CA from every client (``require_certificate``,
  ``allow_anonymous false``) and refuses revoked ones (``crlfile``, the fleet's CRL);
- takes the certificate's id as the client's user name and as its client id
  (``use_identity_as_username``, ``use_username_as_clientid``): a client presenting
  agv-02's certificate is agv-02 whatever client id it asks for, so it cannot take
  over agv-01's session;
- allows each client only the topics its id and role give it (``acl_file``:
  :mod:`agv_app.vda5050.acl`).

It re-reads the PKI's ``members.json`` and CRL when they change (checked every
``watch_s`` by a thread of its own, which touches only those files, the access list and
the mosquitto process): the access list is written anew and mosquitto reloads it and
the CRL (SIGHUP), so a master issued later gets its rights and a revoked certificate
is refused on its next connect (a connection open at the revocation stays until it
closes). A plain listener with anonymous clients
is had only when asked for by name (``insecure``) and only on loopback. Either way: no
persistence, and ``set_tcp_nodelay true`` (without it, QoS 1 round trips were measured
at 88 ms).

``python -m agv_app.vda5050.broker --pki DIR [--id broker] [--listen HOST:PORT]`` runs
one in the foreground until SIGTERM or SIGINT. The configuration's text is written by
:mod:`agv_app.vda5050.mosquitto_config`; this module runs the process.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Final

from agv_app.vda5050.acl import access_list
from agv_app.vda5050.link import BrokerError, MqttLink, probe_broker
from agv_app.vda5050.mosquitto_config import broker_config, find_mosquitto, names_address
from agv_app.vda5050.topics import BrokerAddress
from objectplaces.core.errors import LocalProtocolError
from objectplaces.security import CredentialError, Identity, is_loopback, issued
from objectplaces.security.pki import CRL_FILE, MEMBERS_FILE

__all__ = ["BROKER_ID", "LocalBroker", "broker_config", "find_mosquitto", "main"]

BROKER_ID: Final = "broker"
"""The broker's id in a fleet PKI by default (role ``router``)."""

_HOST: Final = "127.0.0.1"
_RELOADING: Final = "Reloading config."  # what mosquitto logs as it handles SIGHUP


def _free_port(host: str) -> int:
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET) as s:
        s.bind((host, 0))
        port: int = s.getsockname()[1]
        return port


def _accepts(host: str, port: int) -> bool:
    with contextlib.suppress(OSError), socket.create_connection((host, port), timeout=0.2):
        return True
    return False


class LocalBroker:
    """A mosquitto process (``start`` and ``stop``, or ``with``); see the module doc.

    Args:
        tls: the broker's identity (role ``router``, issued for ``host``); the PKI
            folder it comes from (its CA's folder) holds ``members.json``.
        insecure: a plain listener with anonymous clients instead (loopback only).
        host: the address to listen on.
        port: the port (0: a free one).
        executable: the mosquitto binary (default: found on the system).
        start_timeout_s: how long to wait for it to accept connections.
        tcp_nodelay: ``set_tcp_nodelay`` (off only to measure what it saves).
        watch_s: how often the PKI's members and CRL are checked for changes (None:
            never; :meth:`reload` by hand).

    Raises:
        LocalProtocolError: neither ``tls`` nor ``insecure``, or both; a plain listener
            off loopback.
        CredentialError: the identity's certificate does not name ``host``.
    """

    def __init__(
        self,
        tls: Identity | None = None,
        *,
        insecure: bool = False,
        host: str = _HOST,
        port: int = 0,
        executable: str | None = None,
        start_timeout_s: float = 10.0,
        tcp_nodelay: bool = True,
        watch_s: float | None = 1.0,
    ) -> None:
        if (tls is None) == (not insecure):
            raise LocalProtocolError(
                "the broker needs its identity (tls=Identity.from_pki(DIR, 'broker')) or, "
                "for a plain listener on loopback, insecure=True; not both"
            )
        if tls is None and not is_loopback(host):
            raise LocalProtocolError(f"a plain broker listens on loopback only, not on {host}")
        if tls is not None and not names_address(tls, host):
            raise CredentialError(
                f"certificate {tls.cert} of the broker does not name {host}, so no client "
                f"would trust it: issue it with --address {host}"
            )
        self.tls = tls
        self.host = host
        self.port = port
        self.executable = executable or find_mosquitto()
        self.start_timeout_s = start_timeout_s
        self.tcp_nodelay = tcp_nodelay
        self.watch_s = watch_s
        self.address: BrokerAddress | None = None
        self.reloads = 0
        """How often mosquitto reloaded its access list and CRL."""
        self._proc: subprocess.Popen[bytes] | None = None
        self._dir: Path | None = None
        self._watcher: threading.Thread | None = None
        self._stop_watching = threading.Event()
        self._stamp: tuple[tuple[int, int] | None, ...] = ()

    @property
    def running(self) -> bool:
        """Whether mosquitto runs."""
        return self._proc is not None and self._proc.poll() is None

    @property
    def pki(self) -> Path | None:
        """The PKI folder the broker's identity comes from (None: plain)."""
        return None if self.tls is None else self.tls.ca.parent

    def start(self) -> BrokerAddress:
        """Start the broker; return where it listens.

        Raises:
            FileNotFoundError: mosquitto is not installed (``make mosquitto``).
            CredentialError: the PKI's ``members.json`` cannot be read.
            RuntimeError: it did not come up (its log is in the message).
        """
        if self.executable is None:
            raise FileNotFoundError("mosquitto is not installed (make mosquitto)")
        self._dir = Path(tempfile.mkdtemp(prefix="objectplaces-mqtt-"))
        try:
            return self._launch()
        except BaseException:  # SIGTERM's SystemExit included: no mosquitto left behind
            self.stop()
            raise

    def _launch(self) -> BrokerAddress:
        assert self._dir is not None
        assert self.executable is not None
        acl = self._dir / "acl" if self.tls is not None else None
        self._stamp = self._pki_stamp()
        self._write_acl()
        last_log = ""
        # With port 0, another process may take the free port before mosquitto binds it.
        for _ in range(3 if self.port == 0 else 1):
            port = self.port or _free_port(self.host)
            config = self._dir / "mosquitto.conf"
            config.write_text(
                broker_config(
                    host=self.host,
                    port=port,
                    tls=self.tls,
                    acl_file=acl,
                    tcp_nodelay=self.tcp_nodelay,
                )
            )
            log = self._dir / "mosquitto.log"
            with open(log, "wb") as out:
                self._proc = subprocess.Popen(
                    [self.executable, "-c", str(config)],
                    stdin=subprocess.DEVNULL,
                    stdout=out,
                    stderr=subprocess.STDOUT,
                    start_new_session=True,
                )
            deadline = time.monotonic() + self.start_timeout_s
            while time.monotonic() < deadline and self._proc.poll() is None:
                if _accepts(self.host, port):
                    self.address = BrokerAddress(self.host, port, tls=self.tls is not None)
                    self._start_watching()
                    return self.address
                time.sleep(0.05)
            last_log = log.read_text(errors="replace")
            self._kill()
        raise RuntimeError(f"mosquitto did not start:\n{last_log}")

    # -- the PKI's members and CRL ------------------------------------------------------

    def _pki_stamp(self) -> tuple[tuple[int, int] | None, ...]:
        if self.pki is None:
            return ()
        stamps: list[tuple[int, int] | None] = []
        for name in (MEMBERS_FILE, CRL_FILE):
            try:
                status = (self.pki / name).stat()
            except OSError:
                stamps.append(None)
            else:
                stamps.append((status.st_mtime_ns, status.st_size))
        return tuple(stamps)

    def _write_acl(self) -> None:
        if self.pki is None or self._dir is None:
            return
        text = access_list(issued(self.pki))
        tmp = self._dir / "acl.tmp"
        tmp.write_text(text)
        os.replace(tmp, self._dir / "acl")  # mosquitto never reads half a list

    def reload(self) -> bool:
        """Write the access list anew from ``members.json`` and have mosquitto reload it
        and the CRL; return once it has (blocks; bounded by ``start_timeout_s``). A
        ``members.json`` that cannot be read now keeps the list before.

        Returns:
            True once mosquitto enforces what the files say now; False if it is not
            running or did not say it reloaded in time.
        """
        with contextlib.suppress(CredentialError):
            self._write_acl()
        proc, address = self._proc, self.address
        if proc is None or proc.poll() is not None or address is None:
            return False
        before = self._log_size()
        proc.send_signal(signal.SIGHUP)
        deadline = time.monotonic() + self.start_timeout_s
        while _RELOADING not in self._log_from(before):
            if time.monotonic() > deadline or proc.poll() is not None:
                return False
            time.sleep(0.02)
        # mosquitto reloads within one turn of its loop, which has begun: a handshake it
        # answers now, it answers after the reload (one that met the reload may fail).
        with contextlib.suppress(BrokerError):
            probe_broker(MqttLink(address, self.tls), timeout_s=self.start_timeout_s)
        self.reloads += 1
        return True

    def _log_size(self) -> int:
        if self._dir is None:
            return 0
        try:
            return (self._dir / "mosquitto.log").stat().st_size
        except OSError:
            return 0

    def _log_from(self, offset: int) -> str:
        if self._dir is None:
            return ""
        try:
            with open(self._dir / "mosquitto.log", "rb") as log:
                log.seek(offset)
                return log.read().decode(errors="replace")
        except OSError:
            return ""

    def _start_watching(self) -> None:
        if self.pki is None or self.watch_s is None:
            return
        self._stop_watching.clear()
        self._watcher = threading.Thread(
            target=self._watch, args=(self.watch_s,), name="mosquitto-pki-watch", daemon=True
        )
        self._watcher.start()

    def _watch(self, every_s: float) -> None:
        while not self._stop_watching.wait(every_s):
            stamp = self._pki_stamp()
            if stamp != self._stamp:
                self._stamp = stamp
                self.reload()

    # -- stopping -----------------------------------------------------------------------

    def _kill(self) -> None:
        proc, self._proc = self._proc, None
        if proc is None:
            return
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=5.0)

    def stop(self) -> None:
        """Stop the broker and remove its files. Idempotent."""
        watcher, self._watcher = self._watcher, None
        if watcher is not None:
            self._stop_watching.set()
            watcher.join()
        self._kill()
        self.address = None
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

    def log(self) -> str:
        """What mosquitto has logged so far (empty when stopped)."""
        return self._log_from(0)

    def __enter__(self) -> BrokerAddress:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _listen(text: str) -> tuple[str, int]:
    host, sep, port = text.rpartition(":")
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise argparse.ArgumentTypeError(f"expected HOST:PORT, got {text!r}")
    return host.strip("[]"), int(port)


def main(argv: list[str] | None = None) -> int:
    """Run a broker for a fleet in the foreground until SIGTERM or SIGINT.

    Returns:
        The exit status (2: it cannot start).
    """
    parser = argparse.ArgumentParser(
        prog="python -m agv_app.vda5050.broker",
        description="Run mosquitto for a fleet's VDA 5050 traffic: mutual TLS with the "
        "fleet PKI, each certificate allowed only its own topics (docs/vda5050.md).",
    )
    parser.add_argument("--pki", type=Path, required=True, metavar="DIR", help="the fleet PKI")
    parser.add_argument(
        "--id", default=BROKER_ID, help=f"the broker's id in DIR (default {BROKER_ID!r})"
    )
    parser.add_argument(
        "--listen",
        type=_listen,
        default=(_HOST, 8883),
        metavar="HOST:PORT",
        help="where to listen (default 127.0.0.1:8883); the certificate must name HOST",
    )
    args = parser.parse_args(argv)
    host, port = args.listen
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    try:
        broker = LocalBroker(Identity.from_pki(args.pki, args.id), host=host, port=port)
        with broker as address:
            print(f"VDA 5050 broker at {address.url}", flush=True)
            while not stop.wait(1.0):
                if not broker.running:
                    print(f"mosquitto stopped:\n{broker.log()}", file=sys.stderr)
                    return 1
    except (LocalProtocolError, FileNotFoundError, RuntimeError) as exc:
        print(f"broker: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
