"""Who may use the dashboard, tried as an attacker would: no token, a viewer's token, a
forged ``Host``, a foreign ``Origin``, a body that is no JSON, a stolen cookie."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from fastapi.routing import APIRoute

from dashboard.app import create_app
from dashboard.auth import Logins, Tokens
from dashboard.guard import PUBLIC_PATHS, Call, Refused, decide
from objectplaces.security import TemporaryPki
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import (
    FEED_URL,
    ORIGIN,
    WebSocketDenialResponse,
    anonymous,
    logged_in,
)
from tests.dashboard.served import Served
from tests.dashboard.test_app import api_routes

FOREIGN = "http://127.0.0.1:9000"
"""A page of another origin on this machine: another port of the same host."""

OTHER_READS = [
    "/",
    "/docs",
    "/redoc",
    "/docs/oauth2-redirect",
    "/openapi.json",
    "/static/app.js",
    "/static/index.html",
    "/docs-assets/swagger-ui-bundle.js",
]
"""Reads that are no API route: the page, its files, the REST documentation."""


@pytest.fixture
def app(source: NetworkSource) -> FastAPI:
    return create_app(source)


def concrete(path: str) -> str:
    return re.sub(r"\{[^}]+\}", "x", path)


def routes(app: FastAPI, *, changes: bool) -> Iterator[tuple[str, str]]:
    """(method, path) of every API route that reads (``changes=False``) or changes."""
    for route in api_routes(app.routes):
        if not isinstance(route, APIRoute) or route.path in PUBLIC_PATHS:
            continue
        for method in sorted(route.methods or ()):
            if (method != "GET") == changes:
                yield method, concrete(route.path)


def feed_refusal(client: TestClient, **headers: str) -> WebSocketDenialResponse:
    with (
        pytest.raises(WebSocketDenialResponse) as refused,
        client.websocket_connect(FEED_URL, headers=headers),
    ):
        pass
    return refused.value


def test_without_a_token_nothing_is_read(app: FastAPI) -> None:
    stranger = anonymous(app)
    reads = [path for _, path in routes(app, changes=False)] + OTHER_READS
    assert len(reads) > 25
    for path in reads:
        r = stranger.get(path, follow_redirects=False)
        assert r.status_code == 401, (path, r.status_code)
        assert "log in" in r.json()["detail"]
        assert r.headers["WWW-Authenticate"] == "Bearer"
    wrong = {"Authorization": "Bearer " + Tokens.generate().operator}
    for header in (wrong, {"Authorization": f"Basic {app.state.tokens.operator}"}):
        assert stranger.get("/api/nodes", headers=header).status_code == 401
    assert stranger.get("/api/access").json() == {"role": None}
    refused = feed_refusal(stranger)
    assert refused.status_code == 401
    assert "log in" in refused.json()["detail"]


def test_a_browser_without_a_login_is_sent_to_the_login_page(app: FastAPI) -> None:
    stranger = anonymous(app)
    r = stranger.get("/", headers={"Accept": "text/html"}, follow_redirects=False)
    assert (r.status_code, r.headers["location"]) == (303, "/login")
    page = stranger.get("/login")
    assert page.status_code == 200
    assert 'id="login-form"' in page.text
    assert page.headers["Cache-Control"] == "no-store"


def test_without_a_token_nothing_changes(app: FastAPI, source: NetworkSource) -> None:
    stranger = anonymous(app)
    changes = list(routes(app, changes=True))
    assert ("POST", "/api/sim/pause") in changes
    assert ("DELETE", "/api/tasks/x") in changes
    for method, path in changes:
        r = stranger.request(method, path, json={"station": "pick-A1-1", "factor": 2})
        assert r.status_code == 401, (method, path)
    assert (source.paused, source.tasks, source.speed) == (False, [], 1.0)


def test_a_viewer_reads_and_is_refused_every_change(app: FastAPI, source: NetworkSource) -> None:
    viewer = logged_in(app, "viewer")
    assert viewer.get("/api/access").json() == {"role": "viewer"}
    for path in ("/api/nodes", "/api/metrics", "/", "/docs", "/openapi.json"):
        assert viewer.get(path).status_code == 200, path
    with viewer.websocket_connect(FEED_URL) as ws:
        assert ws.receive_json()["type"] == "snapshot"
    for method, path in routes(app, changes=True):
        r = viewer.request(method, path, json={"station": "pick-A1-1", "factor": 2})
        assert r.status_code == 403, (method, path)
        assert "operator" in r.json()["detail"]
    assert (source.paused, source.tasks, source.speed) == (False, [], 1.0)


@pytest.mark.parametrize("host", ["attacker.example", "attacker.example:8000", "127.0.0.1.nip.io"])
def test_a_forged_host_is_refused_token_or_not(app: FastAPI, host: str) -> None:
    """DNS rebinding: a page of ``attacker.example``, whose name now points at this
    machine, sends its own name as ``Host``."""
    operator = logged_in(app)
    assert operator.get("/api/nodes", headers={"Host": host}).status_code == 400
    r = operator.post("/api/sim/pause", json={}, headers={"Host": host})
    assert r.status_code == 400
    assert (
        anonymous(app).post("/login", json={"token": "x"}, headers={"Host": host}).status_code
        == 400
    )
    assert feed_refusal(operator, host=host).status_code == 400
    assert operator.get("/api/nodes", headers={"Host": "localhost:8000"}).status_code == 200
    assert operator.get("/api/nodes", headers={"Host": "[::1]:8000"}).status_code == 200


def test_the_names_the_server_is_reached_by_are_allowed(source: NetworkSource) -> None:
    app = create_app(source, hosts=("floor.lan",))
    client = logged_in(app)
    assert client.get("/api/nodes", headers={"Host": "floor.lan:8000"}).status_code == 200
    assert client.get("/api/nodes", headers={"Host": "attacker.example"}).status_code == 400
    with pytest.raises(ValueError, match="patterns"):
        create_app(source, hosts=("*",))


@pytest.mark.parametrize(
    ("headers", "body", "status"),
    [
        ({}, None, 415),
        ({"Content-Type": "text/plain"}, b'{"reason": "x"}', 415),
        ({"Content-Type": "application/x-www-form-urlencoded"}, b"reason=x", 415),
        ({"Content-Type": "multipart/form-data; boundary=b"}, b"--b--", 415),
        ({"Content-Type": "application/json"}, b"", 422),
    ],
)
def test_a_post_without_a_json_body_is_refused(
    app: FastAPI, source: NetworkSource, headers: dict[str, str], body: bytes | None, status: int
) -> None:
    operator = logged_in(app)
    r = operator.post("/api/sim/pause", content=body, headers=headers)
    assert r.status_code == status, r.text
    assert r.json()["detail"]
    assert not source.paused
    assert operator.post("/api/sim/pause", json={}).status_code == 200
    assert source.paused


@pytest.mark.parametrize("origin", [FOREIGN, "null", "https://127.0.0.1:8000", "http://evil"])
def test_a_change_from_a_foreign_origin_is_refused_even_with_the_token(
    app: FastAPI, source: NetworkSource, origin: str
) -> None:
    operator = logged_in(app)
    r = operator.post("/api/sim/pause", json={}, headers={"Origin": origin})
    assert r.status_code == 403
    assert "is not this dashboard's" in r.json()["detail"]
    r = operator.post("/api/tasks", json={"station": "pick-A1-1"}, headers={"Origin": origin})
    assert r.status_code == 403
    assert operator.delete("/api/tasks/x", headers={"Origin": origin}).status_code == 403
    assert (source.paused, source.tasks) == (False, [])
    assert operator.post("/api/sim/pause", json={}, headers={"Origin": ORIGIN}).status_code == 200


def test_the_feed_from_a_foreign_origin_is_refused(app: FastAPI) -> None:
    operator = logged_in(app)
    refused = feed_refusal(operator, origin=FOREIGN)
    assert refused.status_code == 403
    assert "the feed is taken only from the dashboard's own pages" in refused.json()["detail"]
    with operator.websocket_connect(FEED_URL, headers={"origin": ORIGIN}) as ws:
        assert ws.receive_json()["type"] == "snapshot"


def test_a_login_trades_the_token_for_a_cookie_that_holds_no_token(
    app: FastAPI, source: NetworkSource
) -> None:
    browser = anonymous(app)
    assert browser.post("/login", json={"token": "guess" * 10}).status_code == 401
    assert browser.post("/login", json={"token": 42}).status_code == 422
    r = browser.post("/login", json={"token": app.state.tokens.operator})
    assert r.json() == {"role": "operator"}
    cookie = r.headers["set-cookie"]
    assert cookie.startswith("objectplaces-8000=")
    for attribute in ("HttpOnly", "SameSite=strict", "Path=/"):
        assert attribute in cookie
    assert app.state.tokens.operator not in cookie
    assert "Secure" not in cookie  # plain HTTP on loopback: a Secure cookie would not return
    assert browser.get("/api/access").json() == {"role": "operator"}
    with browser.websocket_connect(FEED_URL, headers={"origin": ORIGIN}) as ws:
        assert ws.receive_json()["type"] == "snapshot"
    # Changes by cookie come from the page, which names its origin.
    assert browser.post("/api/sim/pause", json={}).status_code == 403
    assert browser.post("/api/sim/pause", json={}, headers={"Origin": FOREIGN}).status_code == 403
    assert not source.paused
    assert browser.post("/api/sim/pause", json={}, headers={"Origin": ORIGIN}).status_code == 200
    assert browser.post("/logout", json={}, headers={"Origin": ORIGIN}).json() == {"role": None}
    assert browser.get("/api/access").json() == {"role": None}
    assert browser.get("/api/nodes").status_code == 401


def test_a_cookie_outlives_neither_its_login_nor_a_restart(source: NetworkSource) -> None:
    key = create_app(source).state.logins.open("operator")
    restarted = anonymous(create_app(source), cookies={"objectplaces-8000": key})
    r = restarted.get("/api/nodes")
    assert r.status_code == 401
    assert "the login has ended" in r.json()["detail"]
    page = restarted.get("/", headers={"Accept": "text/html"}, follow_redirects=False)
    assert page.headers["location"] == "/login"


def test_over_tls_the_cookie_is_secure_and_bound_to_the_host(app: FastAPI) -> None:
    browser = TestClient(app, base_url="https://127.0.0.1:8443")
    cookie = browser.post("/login", json={"token": app.state.tokens.viewer}).headers["set-cookie"]
    assert cookie.startswith("__Host-objectplaces-8443=")
    assert "Secure" in cookie
    assert browser.get("/api/access").json() == {"role": "viewer"}


def test_every_answer_refuses_to_be_framed(app: FastAPI) -> None:
    for client, path in ((logged_in(app), "/"), (anonymous(app), "/api/nodes")):
        r = client.get(path)
        assert r.headers["X-Frame-Options"] == "DENY"
        assert "frame-ancestors 'none'" in r.headers.get_list("Content-Security-Policy")


def test_logins_end_after_their_lifetime_and_the_oldest_gives_way() -> None:
    now = [0.0]
    logins = Logins(lifetime_s=10.0, capacity=2, clock=lambda: now[0])
    first, second = logins.open("viewer"), logins.open("operator")
    assert (logins.role_of(first), logins.role_of(second)) == ("viewer", "operator")
    third = logins.open("viewer")
    assert (logins.role_of(first), len(logins)) == (None, 2)
    now[0] = 10.0
    assert logins.role_of(second) is None
    assert logins.role_of(third) is None
    assert len(logins) == 0


def test_tokens_stay_out_of_reprs_and_weak_ones_are_refused() -> None:
    tokens = Tokens.generate()
    assert tokens.operator not in repr(tokens)
    assert tokens.role_of(tokens.viewer) == "viewer"
    assert tokens.role_of(tokens.viewer[:-1]) is None
    assert tokens.role_of("") is None
    with pytest.raises(ValueError, match="32 to 256"):
        Tokens(operator="short", viewer=tokens.viewer)
    with pytest.raises(ValueError, match="must differ"):
        Tokens(operator=tokens.viewer, viewer=tokens.viewer)


@pytest.mark.parametrize(
    ("call", "status"),
    [
        (Call("POST", "/login", ORIGIN, origin=FOREIGN, content_type="application/json"), 403),
        (Call("POST", "/login", ORIGIN, content_type="text/plain"), 415),
        (Call("WEBSOCKET", "/ws/events", ORIGIN, origin="null"), 403),
        (Call("GET", "/api/nodes", ORIGIN, authorization="Bearer"), 401),
    ],
)
def test_the_gate_decides_before_any_route(call: Call, status: int) -> None:
    decision: Any = decide(call, Tokens.generate(), Logins())
    assert isinstance(decision, Refused)
    assert decision.status == status


def test_the_dashboard_serves_tls_with_the_pkis_certificate(source: NetworkSource) -> None:
    with TemporaryPki(fleet="test") as pki:
        identity = pki.identity("control", role="control", addresses=("127.0.0.1",))
        with Served(source, tls=identity) as served:
            assert served.url.startswith("https://")
            assert served.get("/api/access", role="viewer").json() == {"role": "viewer"}
            login = httpx.post(
                served.url + "/login",
                json={"token": served.tokens.operator},
                verify=served.verify,
                timeout=5,
            )
            cookie = login.headers["set-cookie"]
            assert cookie.startswith("__Host-objectplaces-")
            assert "Secure" in cookie
            with pytest.raises(httpx.HTTPError):  # plain HTTP gets nothing from it
                httpx.get(served.url.replace("https", "http") + "/api/access", timeout=5)
            with pytest.raises(httpx.ConnectError):  # nor does a client that trusts another CA
                httpx.get(served.url + "/api/access", timeout=5)
