"""Nodes in other processes through the API: read like local ones, acting refused (422).

Deterministic: the stand-ins (``agv_app.fleet.remote.RemoteNode``) read fixed published
properties beside real nodes on a simulated network; no process is started.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest

from agv_app.fleet.remote import RemoteNode, roles_wire, sessions_wire, traffic_wire
from dashboard.app import create_app
from objectplaces import NodeStats, ParticipationInfo, SessionInfo
from objectplaces.groups import circles_overlap
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import logged_in

REMOTE = "agv-9"
SESSION = f"{REMOTE}#3"


def published() -> dict[str, Any]:
    session = SessionInfo(
        SESSION, REMOTE, "Requester", "voter", frozenset({"agv-1"}), frozenset(), 12.5,
        circles_overlap().to_json(),
    )  # fmt: skip
    return {
        "kind": "agv",
        "position": (30.0, 9.0),
        "hull_length": 1.5,
        "status": "busy",
        "sessions": sessions_wire([session]),
        "roles": roles_wire([ParticipationInfo("agv-1#1", "agv-1", "voter", 11.0)]),
        "traffic": traffic_wire(NodeStats({"property": (7, 700)}, {"ack": (2, 40)}, {})),
    }


class RemoteSource(NetworkSource):
    """Real nodes on a simulated network, and one node heard from another process."""

    def __init__(self) -> None:
        super().__init__()
        self.heard: dict[str, Any] = published()
        self.remote = RemoteNode(REMOTE, lambda: self.heard, clock_offset=10.0)

    def nodes(self) -> Mapping[str, Any]:
        return {**super().nodes(), REMOTE: self.remote}


@pytest.fixture
def remote_client() -> tuple[TestClient, RemoteSource]:
    source = RemoteSource()
    return logged_in(create_app(source)), source


def test_a_remote_node_is_listed_and_detailed_like_a_local_one(
    remote_client: tuple[TestClient, RemoteSource],
) -> None:
    client, _ = remote_client
    nodes = {n["id"]: n for n in client.get("/api/nodes").json()}
    assert nodes[REMOTE]["initiated"] == 1
    assert nodes[REMOTE]["participating"] == 1
    assert nodes[REMOTE]["messages"] == 9
    assert nodes[REMOTE]["bytes"] == 740
    assert "traffic" not in nodes[REMOTE]["properties"]
    r = client.get(f"/api/nodes/{REMOTE}")
    assert r.status_code == 200, r.text
    body = r.json()
    assert [s["id"] for s in body["sessions"]] == [SESSION]
    assert body["sessions"][0]["started_at"] == 2.5, "in the fleet's clock"
    assert body["participations"] == [
        {"session_id": "agv-1#1", "initiator": "agv-1", "role": "voter"}
    ]
    assert body["stats"]["sent"] == {"property": [7, 700]}
    assert body["view"] == {}


def test_a_remote_nodes_session_is_listed_read_and_not_ours_to_stop(
    remote_client: tuple[TestClient, RemoteSource],
) -> None:
    client, _ = remote_client
    listed = [s for s in client.get("/api/sessions").json() if s["node"] == REMOTE]
    assert [s["id"] for s in listed] == [SESSION]
    assert listed[0]["members"] == ["agv-1"]
    path = f"/api/sessions/{SESSION.replace('#', '%23')}"
    assert client.get(path).status_code == 200
    assert client.delete(path).status_code == 409


def test_acting_on_a_remote_node_is_refused_with_422(
    remote_client: tuple[TestClient, RemoteSource],
) -> None:
    client, _ = remote_client
    r = client.post(
        "/api/sessions",
        json={
            "node": REMOTE,
            "role": "poll",
            "participant_role": "poll-responder",
            "definition": {"type": "within", "distance": 30},
            "params": {"property": "status"},
        },
    )
    assert r.status_code == 422, r.text
    assert "own process" in r.json()["detail"]
    within = '{"type": "within", "distance": 5}'
    r = client.get("/api/groups/view", params={"node": REMOTE, "definition": within})
    assert r.status_code == 422, r.text
    assert len(client.get("/api/sessions").json()) == 1, "nothing left behind"


@pytest.mark.parametrize(
    "garbage",
    [
        {"sessions": {"a": 1}, "roles": "x", "traffic": 5},
        {"sessions": [["s", "r", "p", None, "t", None]], "roles": [[1, 2, 3, 4]]},
        {"traffic": {"sent": {"k": ["a", "b"]}, "received": {"k": [1, 2, 3]}}},
        {"position": "nowhere", "sessions": [[SESSION, "r", "p", ["agv-1", 3], 1e308, "d"]]},
    ],
)
def test_garbage_published_by_a_remote_node_never_breaks_a_response(
    remote_client: tuple[TestClient, RemoteSource], garbage: dict[str, Any]
) -> None:
    client, source = remote_client
    source.heard = {**published(), **garbage}
    for path in ("/api/nodes", f"/api/nodes/{REMOTE}", "/api/sessions", "/api/metrics/history"):
        r = client.get(path)
        assert r.status_code == 200, (path, r.text)
