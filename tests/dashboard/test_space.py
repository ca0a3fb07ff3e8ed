"""``GET /api/nodes/{id}/space``: a node's tuplespace, bounded and a page at a time."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.remote import RemoteNode
from dashboard.app import create_app
from dashboard.space import MAX_SPACE_PAGE
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.login import anonymous, logged_in


def test_a_vehicle_s_locks_are_in_its_space_a_page_at_a_time() -> None:
    fleet = Fleet(config=FleetConfig(agvs=3, seed=3, task_until=0.0))
    node = fleet.agvs["agv-01"].node
    for i in range(7):
        node.space.out(("note", i, (1.5, "x")))
    app = create_app(fleet)
    viewer = logged_in(app, "viewer")
    whole = viewer.get("/api/nodes/agv-01/space", params={"limit": MAX_SPACE_PAGE}).json()
    assert whole["node"] == "agv-01"
    assert whole["total"] == len(node.space) == len(whole["tuples"])
    assert whole["total"] >= 8, "its own hull's lock and the notes"
    assert [t for t in whole["tuples"] if t[0] == "note"] == [
        ["note", i, [1.5, "x"]] for i in range(7)
    ]
    pages = [
        viewer.get("/api/nodes/agv-01/space", params={"offset": off, "limit": 3}).json()
        for off in range(0, whole["total"], 3)
    ]
    assert [t for p in pages for t in p["tuples"]] == whole["tuples"]
    assert all(len(p["tuples"]) <= 3 and p["limit"] == 3 for p in pages)
    beyond = viewer.get("/api/nodes/agv-01/space", params={"offset": 10_000}).json()
    assert beyond["tuples"] == []
    assert beyond["total"] == whole["total"]
    assert anonymous(app).get("/api/nodes/agv-01/space").status_code == 401


def test_bad_pages_are_422_and_an_unknown_node_is_named() -> None:
    fleet = Fleet(config=FleetConfig(agvs=2, seed=3, task_until=0.0))
    client = logged_in(create_app(fleet), "viewer")
    for params in (
        {"limit": 0},
        {"limit": MAX_SPACE_PAGE + 1},
        {"offset": -1},
        {"offset": 10**7},
        {"limit": "ten"},
    ):
        r = client.get("/api/nodes/agv-01/space", params=params)
        assert r.status_code == 422, (params, r.text)
        assert r.json()["detail"]
    r = client.get("/api/nodes/agv-77/space")
    assert r.status_code == 404
    detail = r.json()["detail"]
    assert detail.startswith("unknown node 'agv-77' (known: ")
    assert "agv-01" in detail
    assert "observer" in detail


def test_a_node_in_another_process_that_serves_no_space_says_so() -> None:
    source = NetworkSource()
    source._nodes["agv-9"] = RemoteNode("agv-9", lambda: {"kind": "agv"})  # type: ignore[assignment]
    client = logged_in(create_app(source), "viewer")
    r = client.get("/api/nodes/agv-9/space")
    assert r.status_code == 409
    assert r.json()["detail"] == "node agv-9 does not serve its tuplespace"
    assert client.get("/api/nodes/dashboard/space").json()["node"] == "dashboard"
