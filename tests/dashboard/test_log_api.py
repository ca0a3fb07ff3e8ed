"""``GET /api/events``: what the REST calls and the driver's looks at the fleet log."""

from __future__ import annotations

from typing import Any

import pytest

from dashboard.app import create_app
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import logged_in
from tests.dashboard.test_api import start_poll


@pytest.fixture
def app(source: NetworkSource) -> Any:
    return create_app(source)


@pytest.fixture
def logged(app: Any) -> TestClient:
    return logged_in(app)


def texts(client: TestClient, **params: Any) -> list[str]:
    r = client.get("/api/events", params=params)
    assert r.status_code == 200, r.text
    return [e["text"] for e in r.json()["events"]]


def test_sessions_started_and_stopped_over_rest_are_logged(logged: TestClient) -> None:
    sid = start_poll(logged).json()["id"]
    logged.delete(f"/api/sessions/{sid.replace('#', '%23')}")
    body = logged.get("/api/events").json()
    assert [e["text"] for e in body["events"]] == [
        f"session {sid} (poll) started over REST",
        f"session {sid} stopped over REST",
    ]
    assert {e["source"] for e in body["events"]} == {"api"}
    assert body["alarms"] == []
    assert body["dropped"] == 0


def test_pause_and_resume_are_logged_with_why_and_who(logged: TestClient) -> None:
    assert logged.post("/api/sim/pause", json={"reason": "aisle 3 blocked"}).status_code == 200
    assert logged.post("/api/sim/resume", json={}).status_code == 200
    events = logged.get("/api/events").json()["events"]
    who = "(asked by operator at testclient)"
    assert [(e["severity"], e["text"]) for e in events] == [
        ("warning", f"fleet paused: aisle 3 blocked {who}"),
        ("info", f"fleet resumed: asked over REST {who}"),
    ]
    assert texts(logged, severity="warning") == [f"fleet paused: aisle 3 blocked {who}"]


def test_the_driver_logs_nodes_that_leave(
    app: Any, logged: TestClient, source: NetworkSource
) -> None:
    app.state.driver.step(0.0)
    del source._nodes["agv-3"]
    app.state.driver.step(1.0)
    assert texts(logged) == ["watching 4 nodes", "node agv-3 left"]
    assert texts(logged, limit=1) == ["node agv-3 left"]


@pytest.mark.parametrize(
    ("url", "kwargs"),
    [
        ("/api/events?severity=fatal", {}),
        ("/api/events?limit=0", {}),
        ("/api/events?limit=1001", {}),
        ("/api/events?limit=x", {}),
    ],
)
def test_bad_event_queries_are_422(logged: TestClient, url: str, kwargs: dict[str, Any]) -> None:
    r = logged.get(url, **kwargs)
    assert r.status_code == 422
    assert r.json()["detail"]


@pytest.mark.parametrize(
    "body",
    [{"reason": ""}, {"reason": "x" * 201}, {"reason": 3}, {"why": "x"}, [1], "text"],
)
def test_bad_pause_reasons_are_422(logged: TestClient, body: Any) -> None:
    r = logged.post("/api/sim/pause", json=body)
    assert r.status_code == 422, r.text
    assert texts(logged) == []
