"""A dashboard served by a real uvicorn server on a free loopback port.

The server runs its own event loop in a background thread, exactly as
``objectplaces demo`` runs it, so a test (sync or async) talks to it over real sockets.
"""

from __future__ import annotations

import socket
import threading
import time
from typing import Any

import uvicorn

from dashboard.app import create_app
from dashboard.source import FleetSource

__all__ = ["Served"]


class Served:
    """A dashboard listening on a free loopback port in a background thread.

    Args:
        source: the fleet the app wraps (the app advances it while it runs).
        token: passed to ``create_app``.
    """

    def __init__(self, source: FleetSource, *, token: str | None = None) -> None:
        self.source = source
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        self.app = create_app(source, token=token)
        # Keep idle connections open longer than any test runs: with uvicorn's 5 s
        # default, a loaded machine lets the server close a pooled connection just as
        # the client reuses it, and the request fails with a read error that says
        # nothing about the dashboard.
        config = uvicorn.Config(
            self.app, log_level="warning", lifespan="on", timeout_keep_alive=300
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True
        )

    def __enter__(self) -> Served:
        self.thread.start()
        deadline = time.monotonic() + 10
        while not self.server.started:
            assert time.monotonic() < deadline, "the dashboard did not start"
            time.sleep(0.02)
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10)
        self.sock.close()


def wait_for(predicate: Any, timeout: float, what: str) -> Any:
    """Poll ``predicate`` until it gives a true value, which is returned; fail after
    ``timeout`` seconds saying ``what`` did not happen."""
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        assert time.monotonic() < deadline, f"not within {timeout} s: {what}"
        time.sleep(0.1)  # polling a live server or page, not an assertion
