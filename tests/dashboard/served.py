"""A dashboard served by a real uvicorn server on a free loopback port.

The server runs its own event loop in a background thread, exactly as
``objectplaces demo`` runs it, so a test (sync or async) talks to it over real sockets,
with a role's token (``headers``, ``post``, ``delete``) or, in a browser, logged in
through the login URL (``login_url``).
"""

from __future__ import annotations

import socket
import ssl
import threading
import time
from typing import Any

import httpx
import uvicorn

from dashboard.app import create_app
from dashboard.auth import Role, Tokens
from dashboard.source import FleetSource
from objectplaces.security import Identity

__all__ = ["Served"]


class Served:
    """A dashboard listening on a free loopback port in a background thread.

    Args:
        source: the fleet the app wraps (the app advances it while it runs).
        tokens: passed to ``create_app`` (default: new ones).
        tls: serve TLS with this identity's certificate (``https``); ``verify`` then
            trusts its fleet CA alone.
    """

    def __init__(
        self, source: FleetSource, *, tokens: Tokens | None = None, tls: Identity | None = None
    ) -> None:
        self.source = source
        self.tokens = Tokens.generate() if tokens is None else tokens
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        scheme = "https" if tls else "http"
        self.url = f"{scheme}://127.0.0.1:{self.sock.getsockname()[1]}"
        self.verify: ssl.SSLContext | bool = (
            ssl.create_default_context(cafile=str(tls.ca)) if tls else True
        )
        self.app = create_app(source, tokens=self.tokens)
        # Keep idle connections open longer than any test runs: with uvicorn's 5 s
        # default, a loaded machine lets the server close a pooled connection just as
        # the client reuses it, and the request fails with a read error that says
        # nothing about the dashboard.
        config = uvicorn.Config(
            self.app,
            log_level="warning",
            lifespan="on",
            timeout_keep_alive=300,
            ssl_certfile=tls.cert if tls else None,
            ssl_keyfile=tls.key if tls else None,
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True
        )

    def __enter__(self) -> Served:
        self.thread.start()
        deadline = time.monotonic() + 10
        while not self.server.started:
            if not self.thread.is_alive() or time.monotonic() >= deadline:
                self.__exit__()  # nothing left open to trouble the tests after this one
                raise AssertionError("the dashboard did not start (the server's log says why)")
            time.sleep(0.02)
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(timeout=10)
        self.sock.close()

    def login_url(self, role: Role = "operator") -> str:
        """The URL that logs a browser in with ``role``'s token, as the demo prints it."""
        return f"{self.url}/login#token={self.tokens.of(role)}"

    def headers(self, role: Role = "operator") -> dict[str, str]:
        """The ``Authorization`` header of ``role``."""
        return {"Authorization": f"Bearer {self.tokens.of(role)}"}

    def get(
        self, path: str, params: dict[str, str] | None = None, *, role: Role = "operator"
    ) -> httpx.Response:
        """``GET path`` with ``params`` and ``role``'s token."""
        return httpx.get(
            self.url + path,
            params=params,
            headers=self.headers(role),
            timeout=5,
            verify=self.verify,
        )

    def post(self, path: str, body: Any = None, *, role: Role = "operator") -> httpx.Response:
        """``POST path`` with ``body`` as JSON (default ``{}``) and ``role``'s token."""
        return httpx.post(
            self.url + path,
            json={} if body is None else body,
            headers=self.headers(role),
            timeout=5,
            verify=self.verify,
        )

    def delete(self, path: str, *, role: Role = "operator") -> httpx.Response:
        """``DELETE path`` with ``role``'s token."""
        return httpx.delete(
            self.url + path, headers=self.headers(role), timeout=5, verify=self.verify
        )


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
