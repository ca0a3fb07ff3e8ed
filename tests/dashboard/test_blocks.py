"""Closing parts of the floor over REST, on the real simulated fleet: operators only,
404 naming the known ones, 422 for a block that cuts off a station unless forced, no
half-applied change, every change in the event log with who asked, and the reason an
order waits in the task list."""

from __future__ import annotations

from typing import Any

from agv_app.fleet import Fleet, FleetConfig
from dashboard.app import create_app
from tests.dashboard.login import TestClient, anonymous, logged_in

LANE = "M4550>M3925"  # closed, every station stays reachable
SPUR = "A1-1>A1-1e"  # the only way to pick-A1-1


def _fleet() -> Fleet:
    return Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))


def _floor_events(client: TestClient) -> list[str]:
    events: list[dict[str, Any]] = client.get("/api/events").json()["events"]
    return [e["text"] for e in events if e["source"] == "floor"]


def test_only_the_operator_closes_and_reopens() -> None:
    app = create_app(_fleet())
    body = {"kind": "segment", "what": LANE}
    assert anonymous(app).post("/api/blocks", json=body).status_code == 401
    viewer = logged_in(app, "viewer")
    assert viewer.post("/api/blocks", json=body).status_code == 403
    assert viewer.get("/api/blocks").json() == {
        "closable": True,
        "blocks": [],
        "points": [],
        "segments": [],
    }


def test_a_segment_is_closed_listed_logged_and_reopened() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    r = client.post("/api/blocks", json={"kind": "segment", "what": LANE, "reason": "spill"})
    assert r.status_code == 201, r.text
    block = r.json()
    assert (block["id"], block["kind"], block["what"], block["segments"]) == (
        "b1",
        "segment",
        LANE,
        [LANE],
    )
    assert block["by"] == "operator at testclient"
    assert block["polylines"] == [[list(xy) for xy in fleet.layout.segment_coords(LANE)]]
    listed = client.get("/api/blocks").json()
    assert [b["id"] for b in listed["blocks"]] == ["b1"]
    assert listed["segments"] == [LANE]
    assert all(agv.ways is fleet.blocks.ways for agv in fleet.agvs.values())

    r = client.delete("/api/blocks/b1")
    assert r.status_code == 200, r.text
    assert client.get("/api/blocks").json()["blocks"] == []
    assert fleet.blocks.ways is None
    assert _floor_events(client) == [
        f"b1 (segment {LANE}) closed by operator at testclient: spill",
        f"b1 (segment {LANE}) reopened by operator at testclient",
    ]


def test_unknown_paths_points_and_blocks_are_404_naming_the_known_ones() -> None:
    client = logged_in(create_app(_fleet()))
    r = client.post("/api/blocks", json={"kind": "segment", "what": "no-such"})
    assert r.status_code == 404
    detail = r.json()["detail"]
    assert detail.startswith("unknown segment 'no-such' (known: ")
    assert detail.endswith(", ...)"), "a bounded list"
    r = client.post("/api/blocks", json={"kind": "point", "what": "nowhere"})
    assert r.status_code == 404
    assert r.json()["detail"].startswith("unknown point 'nowhere' (known: A1-1, ")
    r = client.delete("/api/blocks/b7")
    assert (r.status_code, r.json()["detail"]) == (404, "unknown block 'b7' (known: none)")
    assert client.post("/api/blocks", json={"kind": "segment", "what": LANE}).status_code == 201
    assert client.delete("/api/blocks/b7").json()["detail"] == "unknown block 'b7' (known: b1)"


def test_a_block_that_cuts_off_a_station_is_422_unless_forced() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    r = client.post("/api/blocks", json={"kind": "segment", "what": SPUR})
    assert r.status_code == 422
    assert "every way out of station(s) pick-A1-1" in r.json()["detail"]
    assert client.get("/api/blocks").json()["blocks"] == [], "nothing half-applied"
    assert fleet.blocks.ways is None
    assert _floor_events(client) == []

    r = client.post("/api/blocks", json={"kind": "segment", "what": SPUR, "force": True})
    assert r.status_code == 201, r.text
    assert _floor_events(client) == [
        f"b1 (segment {SPUR}) closed (forced) by operator at testclient: asked over REST"
    ]


def test_bad_input_is_422() -> None:
    client = logged_in(create_app(_fleet()))
    for body in (
        {"kind": "lane", "what": LANE},
        {"kind": "segment"},
        {"kind": "segment", "what": [[0, 0], [1, 0], [1, 1]]},
        {"kind": "polygon", "what": LANE},
        {"kind": "polygon", "what": [[0, 0], [1, 0]]},
        {"kind": "polygon", "what": [[-90, -90], [-89, -90], [-89, -89]]},
        {"kind": "segment", "what": LANE, "extra": 1},
    ):
        r = client.post("/api/blocks", json=body)
        assert r.status_code == 422, (body, r.text)
    assert client.get("/api/blocks").json()["blocks"] == []


def test_a_polygon_closes_what_it_touches() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    p = fleet.layout.point("M3925")
    square = [[p.x - 0.5, p.y - 0.5], [p.x + 0.5, p.y - 0.5], [p.x + 0.5, p.y + 0.5]]
    r = client.post("/api/blocks", json={"kind": "polygon", "what": square, "force": True})
    assert r.status_code == 201, r.text
    block = r.json()
    assert block["points"] == ["M3925"]
    assert LANE in block["segments"]
    assert block["what"] == square


def test_an_order_that_needs_a_closed_path_says_why_it_waits() -> None:
    fleet = _fleet()
    client = logged_in(create_app(fleet))
    client.post("/api/blocks", json={"kind": "segment", "what": SPUR, "force": True})
    task = fleet.create_task("pick-A1-1", "dock-out-1")
    fleet.advance(5.0)
    listed = {t["id"]: t for t in client.get("/api/tasks").json()}
    assert listed[task]["state"] == "waiting"
    assert listed[task]["waits"] == f"waits: path {SPUR} closed"
    assert client.get(f"/api/tasks/{task}").json()["waits"] == f"waits: path {SPUR} closed"
    client.delete("/api/blocks/b1")
    assert client.get(f"/api/tasks/{task}").json()["waits"] is None


def test_a_fleet_that_cannot_close_says_so(client: TestClient) -> None:
    assert client.get("/api/blocks").json()["closable"] is False
    r = client.post("/api/blocks", json={"kind": "segment", "what": LANE})
    assert r.status_code == 409
    assert client.delete("/api/blocks/b1").status_code == 409
