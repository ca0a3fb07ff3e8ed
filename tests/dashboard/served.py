"""A dashboard served by a real uvicorn server on a free loopback port.

The server runs its own event loop in a background thread, exactly as
``objectplaces demo`` runs it, so a test (sync or async) talks to it over real sockets.
"""

from __future__ import annotations

import socket
import threading
import time

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
