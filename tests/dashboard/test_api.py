"""The REST API and the feed endpoint against real middleware nodes."""

from __future__ import annotations

import json
import time
from typing import Any
from urllib.parse import quote

import pytest

from dashboard.app import create_app
from dashboard.poll import PollInitiator
from objectplaces import groups
from tests.dashboard.conftest import PARKED, NetworkSource, TestClient, advance
from tests.dashboard.login import FEED_URL, logged_in

WITHIN_10 = {"type": "within", "distance": 10.0}
PARKED_IDS = sorted(PARKED)


def start_poll(client: TestClient, **overrides: Any) -> Any:
    body = {
        "node": "agv-1",
        "role": "poll",
        "definition": WITHIN_10,
        "participant_role": "poll-responder",
        "params": {"property": "status"},
    }
    body.update(overrides)
    return client.post("/api/sessions", json=body)


def path(session_id: str) -> str:
    return f"/api/sessions/{quote(session_id, safe='')}"


def test_nodes_list_every_node_with_properties(client: TestClient) -> None:
    r = client.get("/api/nodes")
    assert r.status_code == 200
    nodes = {n["id"]: n for n in r.json()}
    assert sorted(nodes) == ["agv-1", "agv-2", "agv-3", "dashboard"]
    assert nodes["agv-1"]["properties"] == {
        "position": [10.0, 9.0],
        "hull_length": 1.5,
        "status": "idle",
    }
    assert nodes["agv-1"]["messages"] > 0
    assert nodes["agv-1"]["bytes"] > 0
    assert nodes["agv-1"]["initiated"] == 0


def test_node_detail_shows_its_view_and_counters(client: TestClient) -> None:
    r = client.get("/api/nodes/agv-1")
    assert r.status_code == 200
    body = r.json()
    assert body["view"]["agv-2"]["position"] == [14.0, 9.0]
    assert "agv-1" not in body["view"]
    assert body["stats"]["sent"]
    assert body["sessions"] == []
    assert body["participations"] == []


def test_unknown_node_is_404_naming_it(client: TestClient) -> None:
    r = client.get("/api/nodes/agv-99")
    assert r.status_code == 404
    assert "unknown node 'agv-99'" in r.json()["detail"]


def test_poll_session_collects_answers_and_stops(client: TestClient, source: NetworkSource) -> None:
    r = start_poll(client)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    assert r.json()["via_api"] is True
    assert r.json()["role"] == "poll"
    advance(source)

    r = client.get(path(sid))
    assert r.status_code == 200
    detail = r.json()
    # agv-2 is 4 m away; agv-3 and the observer (no position) are not in the group.
    assert detail["members"] == ["agv-2"]
    assert detail["detail"] == {
        "property": "status",
        "answers": {"agv-2": "idle"},
        "missing": [],
        "pending": [],
    }
    assert detail["params"] == {"property": "status"}
    assert detail["definition"] == {"type": "within", "distance": 10.0, "position": "position"}

    listed = client.get("/api/sessions").json()
    assert [s["id"] for s in listed] == [sid]
    assert listed[0]["participant_role"] == "poll-responder"
    assert client.get("/api/nodes/agv-1").json()["initiated"] == 1
    participations = client.get("/api/nodes/agv-2").json()["participations"]
    assert participations == [{"session_id": sid, "initiator": "agv-1", "role": "poll-responder"}]

    r = client.delete(path(sid))
    assert r.status_code == 200
    assert r.json() == {"id": sid, "stopped": True}
    advance(source)
    assert client.get("/api/sessions").json() == []
    assert client.get(path(sid)).status_code == 404
    assert client.get("/api/nodes/agv-2").json()["participations"] == []


def test_poll_for_a_property_a_member_lacks(client: TestClient, source: NetworkSource) -> None:
    sid = start_poll(client, params={"property": "battery"}).json()["id"]
    advance(source)
    detail = client.get(path(sid)).json()["detail"]
    assert detail["answers"] == {}
    assert detail["missing"] == ["agv-2"]


def test_late_joiner_is_polled_too(client: TestClient, source: NetworkSource) -> None:
    sid = start_poll(client).json()["id"]
    advance(source)
    source.nodes()["agv-3"].update_node_property("position", (12.0, 10.0))
    source.nodes()["agv-3"].update_node_property("status", "charging")
    advance(source)
    detail = client.get(path(sid)).json()
    assert detail["members"] == ["agv-2", "agv-3"]
    assert detail["detail"]["answers"] == {"agv-2": "idle", "agv-3": "charging"}


@pytest.mark.parametrize(
    ("overrides", "status", "needle"),
    [
        ({"node": "nope"}, 422, "unknown node 'nope'"),
        ({"role": "dance"}, 422, "unknown initiator role 'dance' (known: poll)"),
        ({"definition": {"type": "square"}}, 422, "unknown group definition type 'square'"),
        ({"definition": {"type": "within"}}, 422, "needs a 'distance'"),
        ({"params": {}}, 422, "needs params {'property'"),
        ({"params": {"property": "x", "extra": 1}}, 422, "takes only 'property'"),
        ({"participant_role": ""}, 422, "participant_role"),
        ({"node": 5}, 422, "node: Input should be a valid string"),
    ],
)
def test_bad_session_requests_say_what_is_wrong(
    client: TestClient, overrides: dict[str, Any], status: int, needle: str
) -> None:
    r = start_poll(client, **overrides)
    assert r.status_code == status
    assert needle in r.json()["detail"]
    assert client.get("/api/sessions").json() == []


def test_missing_field_and_unknown_field_are_422(client: TestClient) -> None:
    r = client.post("/api/sessions", json={"node": "agv-1"})
    assert r.status_code == 422
    assert "role: Field required" in r.json()["detail"]
    r = client.post("/api/tasks", json={"station": "pick-A1-1", "color": "red"})
    assert r.status_code == 422
    assert "color" in r.json()["detail"]


def test_malformed_json_is_400(client: TestClient) -> None:
    r = client.post(
        "/api/sessions", content=b'{"node": "agv-1",', headers={"content-type": "application/json"}
    )
    assert r.status_code == 400
    assert r.json()["detail"].startswith("malformed JSON body")


def test_stopping_unknown_or_foreign_sessions(client: TestClient, source: NetworkSource) -> None:
    r = client.delete(path("agv-1#42"))
    assert r.status_code == 404
    assert "unknown session 'agv-1#42'" in r.json()["detail"]
    own = source.nodes()["agv-2"].start_interaction(
        PollInitiator("status"), groups.within(5.0), "poll-responder"
    )
    r = client.delete(path(own.session_id))
    assert r.status_code == 409
    assert "belongs to the fleet" in r.json()["detail"]
    assert client.get(path(own.session_id)).json()["via_api"] is False


def test_group_view_without_a_session(client: TestClient) -> None:
    r = client.get(
        "/api/groups/view", params={"node": "agv-1", "definition": json.dumps(WITHIN_10)}
    )
    assert r.status_code == 200
    assert r.json()["members"] == ["agv-2"]
    idle = {"type": "property_equals", "name": "status", "value": "idle"}
    wide = {"type": "or", "of": [WITHIN_10, idle]}
    r = client.get("/api/groups/view", params={"node": "agv-1", "definition": json.dumps(wide)})
    assert r.json()["members"] == ["agv-2", "agv-3"]
    # Without a node, the dashboard's observer asks (it has no position of its own).
    r = client.get("/api/groups/view", params={"definition": json.dumps(idle)})
    assert r.json() == {"node": "dashboard", "definition": idle, "members": PARKED_IDS}
    assert client.get("/api/sessions").json() == []


@pytest.mark.parametrize(
    ("params", "status", "needle"),
    [
        ({"node": "ghost", "definition": json.dumps(WITHIN_10)}, 404, "unknown node 'ghost'"),
        ({"node": "agv-1", "definition": "{not json"}, 400, "not valid JSON"),
        ({"node": "agv-1", "definition": "[1, 2]"}, 422, "a group definition is a JSON object"),
        ({"node": "agv-1"}, 422, "definition: Field required"),
        ({}, 422, "definition: Field required"),
    ],
)
def test_group_view_errors(
    client: TestClient, params: dict[str, str], status: int, needle: str
) -> None:
    r = client.get("/api/groups/view", params=params)
    assert r.status_code == status
    assert needle in r.json()["detail"]


def test_tasks(client: TestClient, source: NetworkSource) -> None:
    r = client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 201
    assert r.json() == {"task_id": "task-1", "station": "pick-A1-1"}
    assert source.tasks == ["pick-A1-1"]
    r = client.post("/api/tasks", json={"station": "moon"})
    assert r.status_code == 404
    assert "unknown station 'moon'" in r.json()["detail"]
    r = client.post("/api/tasks", json={"station": "charge-N1175n"})
    assert r.status_code == 422
    assert "charging spot" in r.json()["detail"]


def test_locks_and_metrics(client: TestClient) -> None:
    assert client.get("/api/locks").json() == []
    r = client.get("/api/metrics")
    assert r.status_code == 200
    body = r.json()
    assert body["sim"] == {
        "now": pytest.approx(0.5),
        "paused": False,
        "speed": 1.0,
        "stop": "running",
    }
    assert body["metrics"]["tasks_created"] == 0.0
    assert body["metrics"]["messages"] > 0


def test_sim_controls(client: TestClient, source: NetworkSource) -> None:
    assert client.post("/api/sim/pause", json={}).json()["paused"] is True
    assert source.paused
    assert client.post("/api/sim/resume", json={}).json()["paused"] is False
    assert client.post("/api/sim/speed", json={"factor": 4}).json()["speed"] == 4.0
    assert source.speed == 4.0
    r = client.post("/api/sim/speed", json={"factor": 0})
    assert r.status_code == 422
    assert "factor" in r.json()["detail"]
    r = client.post("/api/sim/rewind", json={})
    assert r.status_code == 404
    assert r.json()["detail"] == "unknown sim action 'rewind' (known: pause, resume, speed)"


def test_page_and_openapi_are_served(client: TestClient) -> None:
    r = client.get("/")
    assert r.status_code == 200
    assert 'id="sessions-panel"' in r.text
    assert client.get("/static/app.js").status_code == 200
    assert client.get("/static/style.css").status_code == 200
    spec = client.get("/openapi.json").json()
    paths = set(spec["paths"])
    assert {
        "/api/nodes",
        "/api/nodes/{node_id}",
        "/api/sessions",
        "/api/sessions/{session_id}",
        "/api/groups/view",
        "/api/locks",
        "/api/tasks",
        "/api/metrics",
        "/api/sim/pause",
        "/api/sim/resume",
        "/api/sim/speed",
    } <= paths
    assert client.get("/docs").status_code == 200


def test_feed_snapshot_then_session_deltas(source: NetworkSource) -> None:
    app = create_app(source, tick_s=0.01)
    with logged_in(app) as client, client.websocket_connect(FEED_URL) as ws:
        snapshot = ws.receive_json()
        assert snapshot["type"] == "snapshot"
        assert snapshot["layout"]["name"] == source.layout.name
        assert len(snapshot["layout"]["stations"]) == len(source.layout.stations)
        assert set(snapshot["nodes"]) == {"dashboard", *PARKED}
        assert snapshot["sessions"] == []
        sid = start_poll(client).json()["id"]
        started: dict[str, Any] | None = None
        deadline = time.monotonic() + 10
        while started is None or not started.get("members"):
            assert time.monotonic() < deadline, "no session in the feed"
            msg = ws.receive_json()
            assert msg["type"] == "delta"
            for s in msg.get("sessions_started", []):
                started = s
            if started is not None and sid in msg.get("members", {}):
                started["members"] = msg["members"][sid]
        assert started["id"] == sid
        assert started["via_api"] is True
        assert started["members"] == ["agv-2"]
        client.delete(path(sid))
        while True:
            msg = ws.receive_json()
            if sid in msg.get("sessions_stopped", []):
                break
