"""``/login``, ``/logout`` and ``GET /api/access``: trading a token for a login cookie.

The login URL the dashboard prints carries the token in its fragment
(``/login#token=...``), which a browser never sends to a server, so it stays out of
logs, proxies and ``Referer`` headers. The login page (``static/login.html``) takes it
out of the address bar at once, sends it here (``POST /login``), and goes on to ``/``
with the cookie this answer sets: ``HttpOnly`` (no script reads it),
``SameSite=Strict``, ``Secure`` over TLS. ``dashboard.auth`` says what the cookie holds.
"""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import FileResponse, JSONResponse
from pydantic import BaseModel, ConfigDict, Field
from starlette.requests import HTTPConnection

from dashboard.auth import LOGIN_LIFETIME_S, Logins, Role, Tokens
from dashboard.errors import ERROR_RESPONSES
from dashboard.guard import cookie_name

__all__ = ["AccessOut", "LoginIn", "LogoutIn", "router"]

router = APIRouter(tags=["access"], responses=ERROR_RESPONSES)


class LoginIn(BaseModel):
    """A token to trade for a login cookie."""

    model_config = ConfigDict(extra="forbid", strict=True)

    token: str = Field(min_length=1, max_length=256, description="the operator's or viewer's")


class LogoutIn(BaseModel):
    """Nothing: ``{}`` (every POST takes a JSON body)."""

    model_config = ConfigDict(extra="forbid", strict=True)


class AccessOut(BaseModel):
    """The caller's role."""

    model_config = ConfigDict(extra="forbid")

    role: Role | None = Field(description="viewer (reads) or operator (reads and changes)")


def _cookie(connection: HTTPConnection) -> tuple[str, bool]:
    secure = connection.url.scheme in ("https", "wss")
    server = connection.scope.get("server")
    return cookie_name(secure=secure, port=server[1] if server else None), secure


@router.get("/login", include_in_schema=False)
async def login_page(request: Request) -> FileResponse:
    """The login page: takes the token from the URL's fragment, or from a form."""
    return FileResponse(
        request.app.state.static_dir / "login.html",
        headers={"Cache-Control": "no-store"},
    )


@router.post("/login", response_model=AccessOut)
async def login(body: LoginIn, request: Request) -> JSONResponse:
    """Trade a token for a login cookie (HttpOnly, SameSite=Strict) of its role."""
    tokens: Tokens = request.app.state.tokens
    logins: Logins = request.app.state.logins
    role = tokens.role_of(body.token)
    if role is None:
        raise HTTPException(401, "not a token of this dashboard")
    name, secure = _cookie(request)
    response = JSONResponse({"role": role}, headers={"Cache-Control": "no-store"})
    response.set_cookie(
        name,
        logins.open(role),
        max_age=int(LOGIN_LIFETIME_S),
        path="/",
        secure=secure,
        httponly=True,
        samesite="strict",
    )
    return response


@router.post("/logout", response_model=AccessOut)
async def logout(body: LogoutIn, request: Request) -> JSONResponse:
    """End the login the cookie holds."""
    logins: Logins = request.app.state.logins
    name, secure = _cookie(request)
    key = request.cookies.get(name)
    if key is not None:
        logins.close(key)
    response = JSONResponse({"role": None})
    response.delete_cookie(name, path="/", secure=secure, httponly=True, samesite="strict")
    return response


@router.get("/api/access", response_model=AccessOut)
async def access(request: Request) -> AccessOut:
    """The caller's role, null when not logged in (open to all: the login page asks)."""
    role: Role | None = request.state.role
    return AccessOut(role=role)
