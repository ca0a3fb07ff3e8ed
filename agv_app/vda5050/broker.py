"""A mosquitto broker on 127.0.0.1 and a free port, for tests and the demo's default.

The broker gets a generated configuration: one listener on the loopback address,
anonymous clients allowed, no persistence, and ``set_tcp_nodelay true`` (without it,
QoS 1 round trips were measured at 88 ms). :class:`LocalBroker` starts it, waits
(bounded) until it accepts connections, and stops it again.
"""

from __future__ import annotations

import contextlib
import shutil
import socket
import subprocess
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from agv_app.vda5050.topics import BrokerAddress, parse_broker_url

__all__ = ["LOCAL", "LocalBroker", "demo_broker", "find_mosquitto"]

_HOST = "127.0.0.1"
_CANDIDATES = ("/usr/sbin/mosquitto", "/usr/local/sbin/mosquitto", "/opt/homebrew/sbin/mosquitto")


def find_mosquitto() -> str | None:
    """The path of the mosquitto executable, or None if it is not installed."""
    found = shutil.which("mosquitto")
    if found:
        return found
    return next((c for c in _CANDIDATES if Path(c).is_file()), None)


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((_HOST, 0))
        port: int = s.getsockname()[1]
        return port


def _accepts(port: int) -> bool:
    with contextlib.suppress(OSError), socket.create_connection((_HOST, port), timeout=0.2):
        return True
    return False


class LocalBroker:
    """A mosquitto process listening on 127.0.0.1 (``start`` and ``stop``, or ``with``).

    Args:
        executable: the mosquitto binary (default: found on the system).
        start_timeout_s: how long to wait for it to accept connections.
        tcp_nodelay: ``set_tcp_nodelay`` (off only to measure what it saves).
    """

    def __init__(
        self,
        executable: str | None = None,
        *,
        start_timeout_s: float = 10.0,
        tcp_nodelay: bool = True,
    ) -> None:
        self.executable = executable or find_mosquitto()
        self.start_timeout_s = start_timeout_s
        self.tcp_nodelay = tcp_nodelay
        self.address: BrokerAddress | None = None
        self._proc: subprocess.Popen[bytes] | None = None
        self._dir: Path | None = None

    def start(self) -> BrokerAddress:
        """Start the broker; return where it listens.

        Raises:
            FileNotFoundError: mosquitto is not installed (``make mosquitto``).
            RuntimeError: it did not come up (its log is in the message).
        """
        if self.executable is None:
            raise FileNotFoundError("mosquitto is not installed (make mosquitto)")
        self._dir = Path(tempfile.mkdtemp(prefix="objectplaces-mqtt-"))
        last_log = ""
        for _ in range(3):  # another process may take the free port before mosquitto binds it
            port = _free_port()
            config = self._dir / "mosquitto.conf"
            config.write_text(
                f"listener {port} {_HOST}\n"
                "allow_anonymous true\n"
                "persistence false\n"
                f"set_tcp_nodelay {'true' if self.tcp_nodelay else 'false'}\n"
                "max_queued_messages 10000\n"
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
                if _accepts(port):
                    self.address = BrokerAddress(_HOST, port)
                    return self.address
                time.sleep(0.05)
            last_log = log.read_text(errors="replace")
            self._kill()
        self.stop()
        raise RuntimeError(f"mosquitto did not start:\n{last_log}")

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
        self._kill()
        self.address = None
        if self._dir is not None:
            shutil.rmtree(self._dir, ignore_errors=True)
            self._dir = None

    def __enter__(self) -> BrokerAddress:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()


LOCAL = "local"
"""The ``--vda5050`` value (or the flag alone) that starts a broker for the demo."""


@contextlib.contextmanager
def demo_broker(value: str | None) -> Iterator[str | None]:
    """The broker URL for ``objectplaces demo --vda5050 [URL]``, started here if asked.

    None stays None (no VDA 5050); :data:`LOCAL` starts mosquitto on 127.0.0.1 and a
    free port for as long as the block runs; any other value must be ``mqtt://HOST:PORT``.

    Raises:
        ValueError: a malformed address.
        FileNotFoundError: :data:`LOCAL` without mosquitto installed.
    """
    if value is None:
        yield None
        return
    if value != LOCAL:
        yield parse_broker_url(value).url
        return
    with LocalBroker() as address:
        yield address.url
