"""The dashboard's own state: bounded, and changed by nothing that only reads."""

from __future__ import annotations

from typing import Any
from urllib.parse import quote

import pytest

from dashboard.app import create_app
from dashboard.poll import PollInitiator
from dashboard.state import ApiSession, ApiSessions, DashboardState
from objectplaces import Session
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import logged_in

POLL = {
    "node": "agv-1",
    "role": "poll",
    "participant_role": "poll-responder",
    "definition": {"type": "within", "distance": 10.0},
    "params": {"property": "status"},
}


def record(node: str = "agv-1") -> ApiSession:
    return ApiSession(
        node, "poll", Session(f"{node}#1", PollInitiator("x")), PollInitiator("x"), {}
    )


def test_api_sessions_are_bounded() -> None:
    sessions = ApiSessions(limit=2)
    sessions.add("a#1", record())
    sessions.add("a#2", record())
    assert sessions.full
    with pytest.raises(OverflowError, match="already 2 sessions"):
        sessions.add("a#3", record())
    assert list(sessions) == ["a#1", "a#2"]
    assert sessions.prune(lambda sid: sid != "a#1") == ["a#1"]
    assert not sessions.full
    sessions.add("a#3", record())
    assert list(sessions) == ["a#2", "a#3"]


def test_reads_change_nothing(client: TestClient, source: NetworkSource) -> None:
    sid = client.post("/api/sessions", json=POLL).json()["id"]
    state: DashboardState = client.app.state.dashboard  # type: ignore[attr-defined]
    source.nodes()["agv-1"].stop_interaction(sid)  # ended behind the API's back
    reads = ["/api/sessions", f"/api/sessions/{quote(sid, safe='')}", "/api/nodes/agv-1"]
    for url in [*reads, "/api/nodes", "/api/locks", "/api/metrics"]:
        assert client.get(url).status_code in (200, 404)
    assert sid in state.api
    assert state.prune() == [sid]


def test_too_many_live_http_sessions_is_429(source: NetworkSource) -> None:
    app = create_app(source)
    state: DashboardState = app.state.dashboard
    state.api.limit = 3
    client = logged_in(app)
    started = [client.post("/api/sessions", json=POLL) for _ in range(3)]
    assert [r.status_code for r in started] == [201, 201, 201]
    r = client.post("/api/sessions", json=POLL)
    assert r.status_code == 429
    assert r.json()["detail"] == "3 sessions started over HTTP are live already; stop one first"
    assert len(client.get("/api/sessions").json()) == 3
    first: dict[str, Any] = started[0].json()
    assert client.delete(f"/api/sessions/{quote(first['id'], safe='')}").status_code == 200
    assert client.post("/api/sessions", json=POLL).status_code == 201
