"""Clients of the dashboard app for the tests: logged in with a role's token, or not.

Every client reaches the app as ``BASE_URL``, a loopback origin the app allows as it
is; a test that plays an attacker changes the ``Host`` or ``Origin`` it sends itself.
"""

from __future__ import annotations

import warnings
from typing import Any

from fastapi import FastAPI
from starlette.exceptions import StarletteDeprecationWarning

from dashboard.auth import Role

# Starlette's test client now prefers the httpx2 package and warns on import when it
# falls back to httpx, which is what the dev extras provide; the warning says nothing
# about this code.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", StarletteDeprecationWarning)
    from starlette.testclient import TestClient as TestClient
    from starlette.testclient import WebSocketDenialResponse as WebSocketDenialResponse

__all__ = [
    "BASE_URL",
    "FEED_URL",
    "ORIGIN",
    "TestClient",
    "WebSocketDenialResponse",
    "anonymous",
    "bearer",
    "logged_in",
]

BASE_URL = "http://127.0.0.1:8000"
ORIGIN = BASE_URL
"""The dashboard's own origin as the test clients reach it."""
FEED_URL = "ws://127.0.0.1:8000/ws/events"
"""The feed (the test client joins a WebSocket's path to its own host, not to ``BASE_URL``)."""


def bearer(app: FastAPI, role: Role = "operator") -> dict[str, str]:
    """The ``Authorization`` header of ``role`` for ``app``."""
    return {"Authorization": f"Bearer {app.state.tokens.of(role)}"}


def logged_in(app: FastAPI, role: Role = "operator", **kwargs: Any) -> TestClient:
    """A test client that sends ``role``'s token with every request and the feed."""
    return TestClient(app, base_url=BASE_URL, headers=bearer(app, role), **kwargs)


def anonymous(app: FastAPI, **kwargs: Any) -> TestClient:
    """A test client with no token (it may still log in and keep the cookie)."""
    return TestClient(app, base_url=BASE_URL, **kwargs)
