"""The gate every request and every feed connection passes, before any route sees it.

Two ASGI middlewares, outermost first (``create_app`` installs them):

1. Starlette's ``TrustedHostMiddleware``: a ``Host`` that is not one of the dashboard's
   own names is refused (400). A page of a site whose name an attacker points at this
   machine's address (DNS rebinding) sends that site's name, so it gets nothing.
2. ``AccessGuard``, which asks of each call, in this order (``decide``, pure):

   - a change (``POST``, ``DELETE`` ...) or the feed that carries an ``Origin`` other
     than the dashboard's own is refused (403): a page of another origin, another port
     of this machine included, can neither change the fleet nor read the feed, even
     though the browser sends it the login cookie (cookies ignore ports, and
     ``SameSite`` counts every port of a host as the same site);
   - outside ``PUBLIC_PATHS`` the caller must prove a role, by a Bearer token or by the
     login cookie (401; a page asked for without either is sent to ``/login``); a change
     made by cookie must carry the page's ``Origin`` (403);
   - a change needs the operator's role (403 for a viewer);
   - a ``POST`` without ``Content-Type: application/json`` is refused (415): a form or
     a plain-text body, the requests a page of another origin may send without asking
     first, never reach a route (the route's model then refuses a missing body, 422).

   It also adds to every answer the headers that keep the pages out of other sites'
   frames (a framed page would take the clicks meant for the framing one).

``docs/dashboard.md`` ("Access") describes the same from the user's side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final
from urllib.parse import urlsplit

from fastapi.responses import JSONResponse, RedirectResponse
from starlette.requests import HTTPConnection
from starlette.responses import Response
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from dashboard.auth import Logins, Role, Tokens

__all__ = [
    "FEED",
    "LOOPBACK_HOSTS",
    "PUBLIC_PATHS",
    "AccessGuard",
    "Admitted",
    "Call",
    "Decision",
    "Refused",
    "ToLogin",
    "call_of",
    "cookie_name",
    "decide",
    "same_origin",
]

LOOPBACK_HOSTS: Final = ("127.0.0.1", "localhost", "[::1]")
"""The names a client on this machine reaches the dashboard by; always allowed."""

PUBLIC_PATHS: Final = frozenset({"/login", "/logout", "/api/access"})
"""Paths open without a role: the login page, logging in and out, and asking whether
one is logged in (a role proved there is still the caller's)."""

FEED: Final = "WEBSOCKET"
"""The ``method`` of a ``Call`` that opens a WebSocket (the feed)."""

_SAFE: Final = frozenset({"GET", "HEAD", "OPTIONS"})
_WITH_BODY: Final = frozenset({"POST", "PUT", "PATCH"})
_DEFAULT_PORTS: Final = {"http": 80, "https": 443}
_HEADERS: Final = (
    (b"x-frame-options", b"DENY"),
    (b"content-security-policy", b"frame-ancestors 'none'"),
    (b"x-content-type-options", b"nosniff"),
    (b"referrer-policy", b"no-referrer"),
)


def cookie_name(*, secure: bool, port: int | None) -> str:
    """The login cookie's name for a server on ``port``.

    One name per port, since cookies ignore ports: two dashboards on one host keep
    their logins apart. Over TLS the name has the ``__Host-`` prefix, which makes the
    browser keep it for this host alone and send it over TLS alone.
    """
    return f"{'__Host-' if secure else ''}objectplaces-{port or 0}"


def same_origin(origin: str, own: str) -> bool:
    """Whether the origin ``origin`` (as a browser sends it) is ``own``; ports that are
    the scheme's default may be written or left out."""
    theirs, ours = _normal(origin), _normal(own)
    return theirs is not None and theirs == ours


def _normal(url: str) -> tuple[str, str, int] | None:
    try:
        parts = urlsplit(url.strip())
        port = parts.port
    except ValueError:
        return None
    scheme = parts.scheme.lower()
    if scheme not in _DEFAULT_PORTS or not parts.hostname or parts.path or parts.query:
        return None
    return scheme, parts.hostname.lower(), port if port is not None else _DEFAULT_PORTS[scheme]


@dataclass(frozen=True, slots=True)
class Call:
    """What the gate looks at in one request or feed connection.

    Attributes:
        method: the HTTP method, or ``FEED`` for a WebSocket.
        path: the path asked for.
        own_origin: the dashboard's origin as this call reached it (scheme and ``Host``).
        origin: the ``Origin`` header, if sent.
        authorization: the ``Authorization`` header, if sent.
        cookie: the login cookie's value, if sent.
        content_type: the ``Content-Type`` header, if sent.
        wants_html: whether the caller asks for a page (``Accept: text/html``).
    """

    method: str
    path: str
    own_origin: str
    origin: str | None = None
    authorization: str | None = None
    cookie: str | None = None
    content_type: str | None = None
    wants_html: bool = False


@dataclass(frozen=True, slots=True)
class Admitted:
    """Let the call through; ``role`` is the caller's (None on a public path)."""

    role: Role | None


@dataclass(frozen=True, slots=True)
class Refused:
    """Answer ``status`` with ``{"detail": detail}``; ``challenge``: ask for a Bearer token."""

    status: int
    detail: str
    challenge: bool = False


@dataclass(frozen=True, slots=True)
class ToLogin:
    """Send the browser to the login page."""


Decision = Admitted | Refused | ToLogin

_LOG_IN = (
    "log in: open the login URL the dashboard printed when it started, or send "
    "'Authorization: Bearer <token>'"
)


def decide(call: Call, tokens: Tokens, logins: Logins) -> Decision:
    """What the gate does with ``call``, given the tokens and the open logins."""
    changes = call.method not in _SAFE
    if changes and call.origin is not None and not same_origin(call.origin, call.own_origin):
        what = "the feed" if call.method == FEED else "a change"
        return Refused(
            403,
            f"Origin {call.origin[:100]!r} is not this dashboard's ({call.own_origin}): "
            f"{what} is taken only from the dashboard's own pages",
        )
    found = _identify(call, tokens, logins)
    if call.path in PUBLIC_PATHS:
        return _without_json(call) or Admitted(found if isinstance(found, str) else None)
    if not isinstance(found, str):
        page = call.wants_html and call.method == "GET"
        return ToLogin() if page else found or Refused(401, _LOG_IN, True)
    if call.cookie is not None and call.authorization is None and changes and not call.origin:
        return Refused(403, "a change made with the login cookie must come from the page")
    if changes and call.method != FEED and found != "operator":
        return Refused(
            403, f"{call.method} {call.path[:100]} changes the fleet: it needs the operator token"
        )
    return _without_json(call) or Admitted(found)


def _identify(call: Call, tokens: Tokens, logins: Logins) -> Role | Refused | None:
    """The caller's role; a refusal for a token or login that proves none; None without
    either. A Bearer token, when sent, decides alone."""
    if call.authorization is not None:
        scheme, _, token = call.authorization.partition(" ")
        role = tokens.role_of(token.strip()) if scheme.lower() == "bearer" else None
        return role or Refused(401, "the Bearer token is not one of this dashboard's", True)
    if call.cookie is not None:
        role = logins.role_of(call.cookie)
        return role or Refused(401, f"the login has ended (12 h, or a restart); {_LOG_IN}", True)
    return None


def _without_json(call: Call) -> Refused | None:
    if call.method not in _WITH_BODY:
        return None
    media = (call.content_type or "").partition(";")[0].strip().lower()
    if media == "application/json":
        return None
    return Refused(415, f"a {call.method} takes a JSON body with 'Content-Type: application/json'")


class AccessGuard:
    """ASGI middleware: lets a call through only as ``decide`` says; marks every answer
    not to be framed. The caller's role is left in the request's state (``role``).

    Args:
        app: the wrapped app.
        tokens: the dashboard's tokens.
        logins: the open logins.
    """

    def __init__(self, app: ASGIApp, *, tokens: Tokens, logins: Logins) -> None:
        self.app = app
        self.tokens = tokens
        self.logins = logins

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Decide about an HTTP request or a WebSocket, then answer or hand it on."""
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        send = _with_headers(send)
        decision = decide(call_of(scope), self.tokens, self.logins)
        response: Response
        match decision:
            case Admitted(role):
                scope["state"] = {**scope.get("state", {}), "role": role}
                await self.app(scope, receive, send)
                return
            case ToLogin():
                response = RedirectResponse("/login", status_code=303)
            case Refused(status, detail, challenge):
                headers = {"WWW-Authenticate": "Bearer"} if challenge else None
                response = JSONResponse({"detail": detail}, status_code=status, headers=headers)
        if scope["type"] == "websocket" and "websocket.http.response" not in scope.get(
            "extensions", {}
        ):
            await send({"type": "websocket.close", "code": 1008})  # a server without denials
            return
        await response(scope, receive, send)


def call_of(scope: Scope) -> Call:
    """The ``Call`` an HTTP or WebSocket scope makes."""
    connection = HTTPConnection(scope)
    headers = connection.headers
    secure = scope.get("scheme") in ("https", "wss")
    server = scope.get("server")
    cookie = cookie_name(secure=secure, port=server[1] if server else None)
    return Call(
        method=FEED if scope["type"] == "websocket" else scope["method"],
        path=scope["path"],
        own_origin=f"{'https' if secure else 'http'}://{headers.get('host', '')}",
        origin=headers.get("origin"),
        authorization=headers.get("authorization"),
        cookie=connection.cookies.get(cookie),
        content_type=headers.get("content-type"),
        wants_html="text/html" in headers.get("accept", ""),
    )


def _with_headers(send: Send) -> Send:
    async def sending(message: Message) -> None:
        if message["type"] in ("http.response.start", "websocket.http.response.start"):
            message = {**message, "headers": [*message.get("headers", ()), *_HEADERS]}
        await send(message)

    return sending
