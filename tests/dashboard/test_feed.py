"""The event feed: snapshot first, then compact deltas, at most 20 a second, latest wins."""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass

import pytest

from agv_app.layout import Layout, Point, Segment, Station
from dashboard.capture import FleetState, PolygonCache, SessionRecord, layout_json, vehicle_json
from dashboard.feed import ClientFeed, FeedHub, diff

LAYOUT = {"points": [], "segments": [], "stations": [], "bounds": [0.0, 0.0, 10.0, 10.0]}


def vehicle(x: float = 0.0, y: float = 0.0, **extra: object) -> dict[str, object]:
    record: dict[str, object] = {
        "x": x,
        "y": y,
        "heading": 0.0,
        "length": 1.0,
        "width": 0.6,
        "status": "idle",
        "task": None,
        "hull": [[x - 0.5, y - 0.3], [x + 0.5, y - 0.3], [x + 0.5, y + 0.3], [x - 0.5, y + 0.3]],
        "hull_length": 0.6,
        "locked": [],
        "requested": [],
    }
    record.update(extra)
    return record


def session(sid: str, *members: str, node: str = "agv-1") -> SessionRecord:
    return SessionRecord(
        session_id=sid,
        node=node,
        role="requester",
        participant_role="voter",
        members=tuple(members),
        started_at=1.0,
    )


def state(now: float = 0.0, **changes: object) -> FleetState:
    base = FleetState(
        now=now,
        paused=False,
        speed=1.0,
        vehicles={"agv-1": vehicle(0.0), "agv-2": vehicle(5.0)},
        sessions={},
        nodes={"agv-1": {"messages": 0, "bytes": 0}},
        metrics={"tasks_completed": 0.0},
    )
    return dataclasses.replace(base, now=now, **changes)  # type: ignore[arg-type]


def test_first_message_is_a_full_snapshot() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state(sessions={"s1": session("s1", "agv-2")}))
    msg = feed.take(now=0.0)
    assert msg is not None
    assert msg["type"] == "snapshot"
    assert msg["seq"] == 0
    assert msg["layout"] == LAYOUT
    assert sorted(msg["vehicles"]) == ["agv-1", "agv-2"]
    assert msg["vehicles"]["agv-1"]["locked"] == []
    assert msg["sessions"][0]["id"] == "s1"
    assert msg["sessions"][0]["members"] == ["agv-2"]
    assert msg["sim"] == {"paused": False, "speed": 1.0, "stop": "running"}
    json.dumps(msg, allow_nan=False)


def test_nothing_pending_means_nothing_to_send() -> None:
    feed = ClientFeed(LAYOUT)
    assert feed.delay(now=0.0) is None
    assert feed.take(now=0.0) is None


def test_delta_carries_only_changed_fields() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state())
    feed.take(now=0.0)
    moved = {"agv-1": vehicle(0.0), "agv-2": vehicle(5.0)}
    moved["agv-1"] = vehicle(0.0, y=0.25) | {"hull": [[0.0, 0.0]]}
    feed.offer(state(now=0.1, vehicles=moved))
    msg = feed.take(now=0.1)
    assert msg == {
        "type": "delta",
        "seq": 1,
        "now": 0.1,
        "vehicles": {"agv-1": {"y": 0.25, "hull": [[0.0, 0.0]]}},
    }


def test_at_most_one_message_per_interval() -> None:
    feed = ClientFeed(LAYOUT, min_interval=0.05)
    feed.offer(state())
    assert feed.take(now=0.0) is not None
    feed.offer(state(now=0.01, vehicles={"agv-1": vehicle(1.0), "agv-2": vehicle(5.0)}))
    assert feed.delay(now=0.01) == pytest.approx(0.04)
    assert feed.take(now=0.01) is None
    assert feed.has_pending
    msg = feed.take(now=0.05)
    assert msg is not None
    assert msg["vehicles"] == {"agv-1": {"x": 1.0, "hull": vehicle(1.0)["hull"]}}


def test_rate_never_exceeds_twenty_a_second() -> None:
    feed = ClientFeed(LAYOUT)
    sent = 0
    # The simulation produces 100 states a second; the client asks after each one.
    for step in range(101):
        now = step / 100
        feed.offer(state(now=now, vehicles={"agv-1": vehicle(now), "agv-2": vehicle(5.0)}))
        if feed.take(now=now) is not None:
            sent += 1
    assert sent == 21  # at 0.00, 0.05, ..., 1.00


def test_slow_client_gets_latest_state_not_a_backlog() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state())
    feed.take(now=0.0)
    for i in range(1, 11):
        feed.offer(state(now=i, vehicles={"agv-1": vehicle(float(i)), "agv-2": vehicle(5.0)}))
    assert feed.coalesced == 9
    msg = feed.take(now=10.0)
    assert msg is not None
    assert msg["now"] == 10
    assert msg["vehicles"] == {"agv-1": {"x": 10.0, "hull": vehicle(10.0)["hull"]}}
    assert not feed.has_pending
    assert feed.take(now=20.0) is None


def test_dropped_states_fold_into_the_next_delta() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state(sessions={"old": session("old", "agv-2")}))
    feed.take(now=0.0)
    # Between two sends: "old" stops, "s1" starts and gains a member, "s2" starts and stops.
    feed.offer(state(now=1, sessions={"s1": session("s1"), "s2": session("s2")}))
    feed.offer(state(now=2, sessions={"s1": session("s1", "agv-2")}))
    msg = feed.take(now=2.0)
    assert msg is not None
    assert [s["id"] for s in msg["sessions_started"]] == ["s1"]
    assert msg["sessions_started"][0]["members"] == ["agv-2"]
    assert msg["sessions_stopped"] == ["old"]
    assert "members" not in msg


def test_membership_change_of_a_live_session() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state(sessions={"s1": session("s1", "agv-2")}))
    feed.take(now=0.0)
    feed.offer(state(now=1, sessions={"s1": session("s1", "agv-3", "agv-2")}))
    msg = feed.take(now=1.0)
    assert msg is not None
    assert msg["members"] == {"s1": ["agv-2", "agv-3"]}
    assert "sessions_started" not in msg


def test_lock_changes_are_reported_apart_from_pose() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state())
    feed.take(now=0.0)
    square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    locked = {"agv-1": vehicle(0.0, locked=[square], requested=[]), "agv-2": vehicle(5.0)}
    feed.offer(state(now=1, vehicles=locked))
    msg = feed.take(now=1.0)
    assert msg is not None
    assert msg["locks"] == {"agv-1": {"locked": [square], "requested": []}}
    assert "vehicles" not in msg


def test_vehicles_appear_and_disappear() -> None:
    old = state()
    new = state(vehicles={"agv-2": vehicle(5.0), "agv-3": vehicle(7.0)})
    body = diff(old, new)
    assert body["vehicles_removed"] == ["agv-1"]
    assert body["vehicles"]["agv-3"]["x"] == 7.0
    assert "locked" not in body["vehicles"]["agv-3"]
    assert body["locks"] == {"agv-3": {"locked": [], "requested": []}}


def test_metrics_send_changed_keys_and_no_nan() -> None:
    old = state(metrics={"tasks_completed": 1.0, "messages": 10.0})
    new = state(metrics={"tasks_completed": 1.0, "messages": 12.0, "tasks_per_hour": math.nan})
    body = diff(old, new)
    assert body == {"metrics": {"messages": 12.0, "tasks_per_hour": None}}
    json.dumps(body, allow_nan=False)


def test_sim_state_changes() -> None:
    assert diff(state(), state(paused=True)) == {
        "sim": {"paused": True, "speed": 1.0, "stop": "running"}
    }
    assert diff(state(), state(speed=4.0)) == {
        "sim": {"paused": False, "speed": 4.0, "stop": "running"}
    }


def test_time_alone_is_no_change() -> None:
    feed = ClientFeed(LAYOUT)
    feed.offer(state())
    feed.take(now=0.0)
    feed.offer(state(now=5.0))
    assert feed.take(now=1.0) is None
    feed.offer(state(now=6.0, paused=True))
    msg = feed.take(now=2.0)
    assert msg is not None
    assert msg["seq"] == 1


def test_node_counters_are_throttled_but_not_lost() -> None:
    feed = ClientFeed(LAYOUT, nodes_interval=0.5)
    feed.offer(state())
    feed.take(now=0.0)
    feed.offer(state(now=0.1, nodes={"agv-1": {"messages": 3, "bytes": 40}}))
    assert feed.take(now=0.1) is None
    feed.offer(state(now=0.2, nodes={"agv-1": {"messages": 5, "bytes": 70}}, paused=True))
    msg = feed.take(now=0.2)
    assert msg is not None
    assert "nodes" not in msg
    feed.offer(state(now=0.6, nodes={"agv-1": {"messages": 5, "bytes": 70}}, paused=True))
    msg = feed.take(now=0.6)
    assert msg is not None
    assert msg["nodes"] == {"agv-1": {"messages": 5, "bytes": 70}}


def test_hub_offers_each_state_to_every_client() -> None:
    hub = FeedHub()
    a, b = ClientFeed(LAYOUT), ClientFeed(LAYOUT)
    ha = hub.add(a)
    hub.add(b)
    hub.publish(state())
    assert len(hub) == 2
    assert a.has_pending
    assert b.has_pending
    hub.remove(ha)
    hub.remove(ha)
    assert len(hub) == 1


@dataclass(frozen=True)
class _Vehicle:
    id: str
    x: float
    y: float
    heading_rad: float
    length_m: float
    width_m: float
    status: str
    task_id: str | None
    hull: list[tuple[float, float]]
    hull_length: float
    locked: list[list[tuple[float, float]]]
    requested: list[list[tuple[float, float]]]


def test_vehicle_record_is_rounded_plain_json() -> None:
    v = _Vehicle(
        "agv-1", 1.23456, 2.0, math.pi, 1.0, 0.5, "driving", "t1",
        [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0000004)], 3.14159, [[(0.0, 0.0)]], [],
    )  # fmt: skip
    record = vehicle_json(v)
    assert record["x"] == 1.235
    assert record["heading"] == 3.1416
    assert record["hull"][2] == [1.0, 1.0]
    assert record["locked"] == [[[0.0, 0.0]]]
    assert record["task"] == "t1"
    json.dumps(record, allow_nan=False)


def test_layout_json_draws_paths_and_places_stations_on_their_points() -> None:
    layout = Layout(
        points=[Point("a", 0.0, 0.0), Point("b", 10.0, 0.0), Point("c", 10.0, 4.0)],
        segments=[
            Segment("ab", "a", "b", via=((5.0, -2.0),)),
            Segment("bc", "b", "c", bidirectional=True),
            Segment("ca", "c", "a"),
        ],
        stations=[Station("s1", "c", "pick"), Station("s2", "a", "parking")],
        name="tiny",
    )
    out = layout_json(layout)
    assert out["name"] == "tiny"
    assert out["bounds"] == [0.0, -2.0, 10.0, 4.0]
    ab = next(s for s in out["segments"] if s["id"] == "ab")
    assert ab["polyline"] == [[0.0, 0.0], [5.0, -2.0], [10.0, 0.0]]
    assert ab["bidirectional"] is False
    assert [s["bidirectional"] for s in out["segments"]] == [False, True, False]
    assert out["stations"][0] == {"id": "s1", "kind": "pick", "point": "c", "x": 10.0, "y": 4.0}
    json.dumps(out, allow_nan=False)


def test_polygon_cache_reuses_json_and_forgets_unused_polygons() -> None:
    cache = PolygonCache(keep=1)
    square = ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))
    first = cache.polygon(square)
    assert first == [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    assert cache.polygon(tuple(square)) is first
    assert cache.polygon([list(p) for p in square]) == first  # lists are not cached
    assert len(cache) == 1
    cache.next_generation()
    assert cache.polygon(square) is first
    cache.next_generation()
    cache.next_generation()
    assert len(cache) == 0
    assert cache.polygon(([0.0, 0.0], [1.0, 1.0])) == [[0.0, 0.0], [1.0, 1.0]]
