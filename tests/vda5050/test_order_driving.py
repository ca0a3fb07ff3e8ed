"""Orders driven by one AGV on the simulated network: progress, updates, pause, cancel."""

from __future__ import annotations

import json

from agv_app.tasks.auction import TaskSpec
from agv_app.vda5050.validation import schema_errors
from tests.vda5050.harness import OneVehicle, instant, make_order


def far_point(v: OneVehicle) -> list[str]:
    station = v.layout.station(sorted(v.layout.stations)[0])
    return v.path(station.point)


def test_an_order_is_driven_node_by_node_to_its_end() -> None:
    v = OneVehicle()
    path = far_point(v)
    assert len(path) >= 4
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    state = v.state()
    assert schema_errors("state", state) == []
    assert state["errors"] == []
    assert [n["nodeId"] for n in state["nodeStates"]] == path[1:]
    seen = [len(path) - 1]
    for _ in range(600):
        v.run(0.5)
        remaining = len(v.state()["nodeStates"])
        if remaining != seen[-1]:
            seen.append(remaining)
        if remaining == 0 and not v.agv.driving:
            break
    assert seen == list(range(len(path) - 1, -1, -1))
    final = v.state()
    assert final["lastNodeId"] == path[-1]
    assert final["edgeStates"] == []
    assert final["driving"] is False
    assert v.agv.point == path[-1]
    assert v.agv.status == "idle"


def test_the_vehicle_stops_at_the_base_end_and_goes_on_after_an_update() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle(
        "order", json.dumps(make_order(v.layout, "agv-01", path, released=2)).encode()
    )
    v.run(60)
    state = v.state()
    assert state["lastNodeId"] == path[1]
    assert state["newBaseRequest"] is True
    assert all(not n["released"] for n in state["nodeStates"])
    update = make_order(v.layout, "agv-01", path[1:], update_id=1, first_sequence=2)
    v.endpoint.handle("order", json.dumps(update).encode())
    assert v.state()["errors"] == []
    assert v.state()["orderUpdateId"] == 1
    v.run(120)
    assert v.state()["lastNodeId"] == path[-1]
    assert v.state()["nodeStates"] == []


def test_stale_and_unstitched_updates_are_rejected() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle(
        "order", json.dumps(make_order(v.layout, "agv-01", path, released=2)).encode()
    )
    bad = make_order(v.layout, "agv-01", path[2:], update_id=1, first_sequence=4)
    v.endpoint.handle("order", json.dumps(bad).encode())
    assert [e["errorType"] for e in v.state()["errors"]] == ["START_NODE_OUT_OF_RANGE"]
    again = make_order(v.layout, "agv-01", path, released=2)
    v.endpoint.handle("order", json.dumps(again).encode())  # the same orderUpdateId: ignored
    assert len(v.state()["errors"]) == 1
    other = make_order(v.layout, "agv-01", path, order_id="order-2")
    v.endpoint.handle("order", json.dumps(other).encode())
    assert [e["errorType"] for e in v.state()["errors"]][-1] == "OTHER_ORDER_ACTIVE"


def test_malformed_and_impossible_orders_leave_errors_and_the_vehicle_works() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle("order", b"{not json")
    v.endpoint.handle("order", json.dumps({"orderId": 3}).encode())
    wrong_edge = make_order(v.layout, "agv-01", path)
    wrong_edge["edges"][0]["edgeId"] = "no-such-edge"
    v.endpoint.handle("order", json.dumps(wrong_edge).encode())
    unknown = make_order(v.layout, "agv-01", path)
    unknown["nodes"][-1]["nodeId"] = "nowhere"
    v.endpoint.handle("order", json.dumps(unknown).encode())
    elsewhere = make_order(v.layout, "agv-01", path[1:])
    v.endpoint.handle("order", json.dumps(elsewhere).encode())
    state = v.state()
    assert schema_errors("state", state) == []
    assert [e["errorType"] for e in state["errors"]] == [
        "VALIDATION_FAILURE",
        "VALIDATION_FAILURE",
        "NO_ROUTE_TO_TARGET",
        "NO_ROUTE_TO_TARGET",
        "START_NODE_OUT_OF_RANGE",
    ]
    refs = {r["referenceKey"] for e in state["errors"] for r in e["errorReferences"]}
    assert {"edgeId", "nodeId", "orderId"} <= refs
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    assert v.state()["errors"] == []
    v.run(150)
    assert v.state()["lastNodeId"] == path[-1]


def test_pause_brakes_and_stop_pause_drives_on() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    for _ in range(300):
        v.run(0.1)
        if v.agv.vehicle.speed > 1.0:
            break
    v.endpoint.handle(
        "instantActions", json.dumps(instant("agv-01", ("p1", "startPause"))).encode()
    )
    assert v.state()["instantActionStates"][0]["actionStatus"] == "RUNNING"
    v.run(5)
    v.endpoint.due(1e9)
    state = v.state()
    assert state["paused"] is True
    assert state["driving"] is False
    assert state["instantActionStates"][0]["actionStatus"] == "FINISHED"
    assert v.agv.vehicle.hard_stops == 0
    stopped_at = v.agv.vehicle.s
    v.run(3)
    assert v.agv.vehicle.s == stopped_at
    v.endpoint.handle("instantActions", json.dumps(instant("agv-01", ("p2", "stopPause"))).encode())
    v.run(150)
    assert v.state()["lastNodeId"] == path[-1]


def test_cancel_stops_at_the_next_node_it_can_and_clears_the_order() -> None:
    v = OneVehicle()
    path = far_point(v)
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    for _ in range(300):
        v.run(0.1)
        if len(v.state()["nodeStates"]) <= len(path) - 3:
            break
    v.endpoint.handle(
        "instantActions", json.dumps(instant("agv-01", ("c1", "cancelOrder"))).encode()
    )
    v.run(30)
    v.endpoint.due(1e9)
    state = v.state()
    assert state["nodeStates"] == []
    assert state["edgeStates"] == []
    assert state["driving"] is False
    assert state["orderId"] == "order-1"
    assert state["instantActionStates"][0]["actionStatus"] == "FINISHED"
    assert state["lastNodeId"] in path[:-1]
    assert v.agv.point == state["lastNodeId"]
    assert v.agv.vehicle.hard_stops == 0
    v.endpoint.handle(
        "instantActions", json.dumps(instant("agv-01", ("c2", "cancelOrder"))).encode()
    )
    assert v.state()["errors"][-1]["errorType"] == "NO_ORDER_TO_CANCEL"
    back = list(v.layout.shortest_path(v.agv.point, v.home))
    v.endpoint.handle(
        "order", json.dumps(make_order(v.layout, "agv-01", back, order_id="o2")).encode()
    )
    v.run(120)
    assert v.state()["lastNodeId"] == v.home


def test_factsheet_and_state_requests_answer_with_valid_messages() -> None:
    v = OneVehicle()
    out = v.endpoint.handle(
        "instantActions",
        json.dumps(instant("agv-01", ("f", "factsheetRequest"), ("s", "stateRequest"))).encode(),
        now=0.0,
    )
    kinds = {o.subtopic: o.message for o in out}
    assert set(kinds) == {"factsheet", "state"}
    assert schema_errors("factsheet", kinds["factsheet"]) == []
    assert schema_errors("state", kinds["state"]) == []
    for o in v.endpoint.due(0.0):
        assert schema_errors(o.subtopic, o.message) == []
    v.endpoint.handle("instantActions", json.dumps(instant("agv-01", ("x", "liftUp"))).encode())
    assert v.state()["instantActionStates"][-1]["actionStatus"] == "FAILED"


def test_an_order_and_a_desk_task_never_run_at_once() -> None:
    v = OneVehicle()
    path = far_point(v)
    pick = sorted(v.layout.stations)[0]
    task = TaskSpec("task-1", pick, pick)
    assert v.agv.bid_for(task) is not None, "idle without an order: it bids"
    v.endpoint.handle("order", json.dumps(make_order(v.layout, "agv-01", path)).encode())
    assert v.agv.status == "busy"
    assert v.agv.bid_for(task) is None, "running an order: no bid"
    v.run(150)
    assert v.state()["nodeStates"] == []
    assert v.agv.bid_for(task) is not None
    v.agv.take(task)
    back = list(v.layout.shortest_path(v.agv.point, v.home))
    v.endpoint.handle(
        "order", json.dumps(make_order(v.layout, "agv-01", back, order_id="o2")).encode()
    )
    error = v.state()["errors"][-1]
    assert error["errorType"] == "OTHER_ORDER_ACTIVE"
    assert "task" in error["errorDescription"]
    assert v.state()["orderId"] == "order-1"
