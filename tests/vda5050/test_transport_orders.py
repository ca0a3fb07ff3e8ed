"""Transport orders on one AGV (simulated network, virtual time): pick and drop with their
action states and loads, charging, the 3.0 error types, instant actions, the factsheet."""

from __future__ import annotations

import itertools
from typing import Any

import pytest

from agv_app.vda5050.actions import CATALOGUE
from agv_app.vda5050.endpoint import MIN_STATE_INTERVAL_S
from agv_app.vda5050.validation import schema_errors
from tests.vda5050.harness import OneVehicle, action, header, instant, make_order

PICK = "pick-A3-1"
DROP = "drop-A4-3"
CHARGER = "charge-N2175n"


def transport_points(v: OneVehicle, pick: str = PICK, drop: str = DROP) -> list[str]:
    """From the AGV's home to ``pick``, to ``drop``, and home again."""
    a, b = v.layout.station(pick).point, v.layout.station(drop).point
    legs = [v.path(a), list(v.layout.shortest_path(a, b)), list(v.layout.shortest_path(b, v.home))]
    return [*legs[0], *legs[1][1:], *legs[2][1:]]


def transport_order(v: OneVehicle, order_id: str = "t-1", **kw: Any) -> dict[str, Any]:
    points = transport_points(v)
    i_pick = points.index(v.layout.station(PICK).point)
    i_drop = points.index(v.layout.station(DROP).point)
    actions = {
        i_pick: [action("pick-1", "pick", loadId="L1", loadType="EPAL", stationName=PICK)],
        i_drop: [action("drop-1", "drop", loadId="L1")],
    }
    return make_order(v.layout, "agv-01", points, order_id=order_id, actions=actions, **kw)


def action_status(state: dict[str, Any], action_id: str) -> Any:
    return next(a["actionStatus"] for a in state["actionStates"] if a["actionId"] == action_id)


def test_a_transport_order_picks_carries_and_drops_the_load() -> None:
    v = OneVehicle()
    v.send("order", transport_order(v))
    state = v.state()
    assert state["errors"] == []
    assert schema_errors("state", state) == []
    assert [action_status(state, a) for a in ("pick-1", "drop-1")] == ["WAITING", "WAITING"]
    assert state["loads"] == []
    pick_point = v.layout.station(PICK).point
    started = v.run_until(lambda: action_status(v.state(), "pick-1") == "RUNNING", within=300)
    assert v.agv.point == pick_point
    assert v.state()["lastNodeId"] == pick_point
    assert v.agv.display_status() == "loading"
    at = v.agv.vehicle.s
    done = v.run_until(lambda: action_status(v.state(), "pick-1") == "FINISHED", within=30)
    # The station's load handling time, standing still all along (HARD).
    assert done - started == pytest.approx(v.agv.config.dwell, abs=0.25)
    assert v.agv.vehicle.s == at
    assert v.state()["loads"] == [{"loadId": "L1", "loadType": "EPAL"}]
    v.run_until(lambda: action_status(v.state(), "drop-1") == "RUNNING", within=300)
    assert v.agv.point == v.layout.station(DROP).point
    assert v.state()["loads"] == [{"loadId": "L1", "loadType": "EPAL"}]
    v.run_until(lambda: action_status(v.state(), "drop-1") == "FINISHED", within=30)
    assert v.state()["loads"] == []
    v.run_until(lambda: v.state()["nodeStates"] == [] and not v.agv.driving, within=300)
    final = v.state()
    assert final["lastNodeId"] == v.home
    assert final["errors"] == []
    assert schema_errors("state", final) == []
    assert v.agv.status == "idle"


def test_a_new_order_waits_until_the_last_actions_have_ended() -> None:
    v = OneVehicle()
    points = [v.home]
    order = make_order(v.layout, "agv-01", points, actions={0: [action("c", "startCharging")]})
    v.send("order", order)  # no charger at home
    assert v.state()["errors"][-1]["errorType"] == "INVALID_ORDER_ACTION"
    pick = v.layout.station(PICK).point
    first = make_order(
        v.layout,
        "agv-01",
        [*v.path(pick)],
        actions={len(v.path(pick)) - 1: [action("p", "pick", "SOFT")]},
    )
    v.send("order", first)
    v.run_until(lambda: action_status(v.state(), "p") == "RUNNING", within=300)
    assert v.state()["nodeStates"] == []
    second = make_order(v.layout, "agv-01", [pick], order_id="o2")
    v.send("order", second)
    assert v.state()["errors"][-1]["errorType"] == "OTHER_ORDER_ACTIVE"
    v.run_until(lambda: action_status(v.state(), "p") == "FINISHED", within=30)
    v.send("order", second)
    assert v.state()["orderId"] == "o2"
    assert v.state()["errors"] == []
    assert v.state()["actionStates"] == []


def test_charging_on_a_charger_of_the_layout() -> None:
    v = OneVehicle()
    charger = v.layout.station(CHARGER).point
    path = v.path(charger)
    order = make_order(
        v.layout, "agv-01", path, actions={len(path) - 1: [action("c1", "startCharging", "NONE")]}
    )
    v.send("order", order)
    v.run_until(lambda: v.state()["powerSupply"]["charging"], within=400)
    assert v.agv.point == charger
    assert action_status(v.state(), "c1") == "FINISHED"
    level = v.state()["powerSupply"]["stateOfCharge"]
    v.run(10)
    assert v.state()["powerSupply"]["stateOfCharge"] > level
    v.send("instantActions", instant("agv-01", ("s1", "stopCharging")))
    state = v.state()
    assert state["powerSupply"]["charging"] is False
    assert state["instantActionStates"][-1]["actionStatus"] == "FINISHED"
    v.send("instantActions", instant("agv-01", ("s2", "startCharging")))
    assert v.state()["powerSupply"]["charging"] is True
    back = list(v.layout.shortest_path(charger, v.home))
    v.send("order", make_order(v.layout, "agv-01", back, order_id="home"))
    v.run_until(lambda: v.agv.driving, within=30)
    assert v.state()["powerSupply"]["charging"] is False, "driving off the charger stops it"
    v.run_until(lambda: not v.agv.book_of_orders.active, within=400)
    v.send("instantActions", instant("agv-01", ("s3", "startCharging")))
    state = v.state()
    assert state["instantActionStates"][-1]["actionStatus"] == "FAILED"
    assert state["errors"][-1]["errorType"] == "INVALID_INSTANT_ACTION"
    assert schema_errors("state", state) == []


def rejected(v: OneVehicle, order: dict[str, Any]) -> Any:
    before = len(v.state()["errors"])
    v.send("order", order)
    errors = v.state()["errors"]
    assert len(errors) == before + 1, errors
    return errors[-1]


def test_each_refusal_has_its_3_0_error_type() -> None:
    v = OneVehicle()
    points = transport_points(v)
    i_pick = points.index(v.layout.station(PICK).point)

    not_a_pick = make_order(v.layout, "agv-01", points, actions={1: [action("x", "pick")]})
    assert rejected(v, not_a_pick)["errorType"] == "INVALID_ORDER_ACTION"
    lift = make_order(v.layout, "agv-01", points, actions={i_pick: [action("l", "liftUp")]})
    assert rejected(v, lift)["errorType"] == "INVALID_ORDER_ACTION"
    none = make_order(v.layout, "agv-01", points, actions={i_pick: [action("p", "pick", "NONE")]})
    assert rejected(v, none)["errorType"] == "INVALID_ORDER_ACTION"
    on_edge = make_order(v.layout, "agv-01", points)
    on_edge["edges"][0]["actions"] = [action("e", "pick")]
    assert rejected(v, on_edge)["errorType"] == "INVALID_ORDER_ACTION"
    high = make_order(
        v.layout, "agv-01", points, actions={i_pick: [action("h", "pick", height=1.0)]}
    )
    assert rejected(v, high)["errorType"] == "INVALID_ORDER_ACTION"

    speed = make_order(v.layout, "agv-01", points)
    speed["edges"][0]["maximumSpeed"] = 0.5
    error = rejected(v, speed)
    assert (error["errorType"], error["errorLevel"]) == ("UNSUPPORTED_PARAMETER", "CRITICAL")
    assert {"referenceKey": "parameter", "referenceValue": "order.edges.maximumSpeed"} in error[
        "errorReferences"
    ]
    other_map = make_order(v.layout, "agv-01", points)
    p = v.layout.point(points[1])
    other_map["nodes"][1]["nodePosition"] = {"x": p.x, "y": p.y, "mapId": "floor-2"}
    assert rejected(v, other_map)["errorType"] == "UNKNOWN_MAP_ID"
    elsewhere = make_order(v.layout, "agv-01", points)
    elsewhere["nodes"][1]["nodePosition"] = {"x": p.x + 3, "y": p.y, "mapId": v.layout.name}
    assert rejected(v, elsewhere)["errorType"] == "NO_ROUTE_TO_TARGET"
    assert rejected(v, {"orderId": "broken"})["errorType"] == "VALIDATION_FAILURE"

    placed = make_order(v.layout, "agv-01", points, released=3)
    for node in placed["nodes"]:
        q = v.layout.point(node["nodeId"])
        node["nodePosition"] = {"x": q.x, "y": q.y, "mapId": v.layout.name}
    v.send("order", placed)
    assert v.state()["errors"] == [], "a new order taken ends the earlier orders' errors"
    v.send("order", placed)  # resent as it was: ignored
    assert v.state()["errors"] == []
    changed = dict(placed, orderDescription="other content")
    assert rejected(v, changed)["errorType"] == "SAME_ORDER_UPDATE_ID"
    update = make_order(v.layout, "agv-01", points[2:], update_id=2, first_sequence=4)
    v.send("order", update)
    assert v.state()["orderUpdateId"] == 2
    older = make_order(v.layout, "agv-01", points[2:], update_id=1, first_sequence=4)
    assert rejected(v, older)["errorType"] == "OUTDATED_ORDER_UPDATE"
    v.send("instantActions", instant("agv-01", ("c", "cancelOrder")))
    later = make_order(v.layout, "agv-01", points[2:], update_id=3, first_sequence=4)
    assert rejected(v, later)["errorType"] == "ORDER_UPDATE_FOLLOWING_CANCEL"
    v.send("instantActions", instant("agv-01", ("c2", "cancelOrder")))
    assert v.state()["errors"][-1]["errorType"] == "NO_ORDER_TO_CANCEL"
    v.send("instantActions", instant("agv-01", ("j", "jump")))
    error = v.state()["errors"][-1]
    assert error["errorType"] == "INVALID_INSTANT_ACTION"
    assert error["errorReferences"] == [{"referenceKey": "actionId", "referenceValue": "j"}]
    v.send("instantActions", instant("agv-01", ("s", "stateRequest")))
    kinds = [e["errorType"] for e in v.state()["errors"]]
    assert "INVALID_INSTANT_ACTION" not in kinds, "it lasts until an instant action is taken"
    assert schema_errors("state", v.state()) == []


def test_cancel_during_a_pick_lets_it_finish_then_finishes() -> None:
    v = OneVehicle()
    v.send("order", transport_order(v))
    v.run_until(lambda: action_status(v.state(), "pick-1") == "RUNNING", within=300)
    v.send("instantActions", instant("agv-01", ("c", "cancelOrder")))
    state = v.state()
    assert action_status(state, "drop-1") == "FAILED"
    assert action_status(state, "pick-1") == "RUNNING", "a pick under way is not cancelled"
    assert state["instantActionStates"][-1]["actionStatus"] == "RUNNING"
    v.run_until(lambda: action_status(v.state(), "pick-1") == "FINISHED", within=30)
    v.endpoint.due(1e9)
    state = v.state()
    assert state["instantActionStates"][-1]["actionStatus"] == "FINISHED"
    assert state["nodeStates"] == []
    assert state["loads"] == [{"loadId": "L1", "loadType": "EPAL"}]
    assert not v.agv.book_of_orders.active


def test_pause_during_a_pick_pauses_it() -> None:
    v = OneVehicle()
    v.send("order", transport_order(v))
    v.run_until(lambda: action_status(v.state(), "pick-1") == "RUNNING", within=300)
    v.send("instantActions", instant("agv-01", ("p", "startPause")))
    assert action_status(v.state(), "pick-1") == "PAUSED"
    v.run(20)
    assert action_status(v.state(), "pick-1") == "PAUSED"
    v.send("instantActions", instant("agv-01", ("r", "stopPause")))
    v.run_until(lambda: action_status(v.state(), "pick-1") == "FINISHED", within=30)


def test_instant_action_states_stay_until_cleared_and_a_full_list_says_so() -> None:
    v = OneVehicle()
    v.endpoint.max_instant_action_states = 5
    for k in range(5):
        v.send("instantActions", instant("agv-01", (f"s{k}", "stateRequest")))
    assert [a["actionId"] for a in v.state()["instantActionStates"]] == [f"s{k}" for k in range(5)]
    assert v.state()["errors"] == []
    v.send("instantActions", instant("agv-01", ("s5", "stateRequest")))
    state = v.state()
    assert [a["actionId"] for a in state["instantActionStates"]][-1] == "s5"
    assert len(state["instantActionStates"]) == 5
    (full,) = state["errors"]
    assert (full["errorType"], full["errorLevel"]) == ("INSTANT_ACTION_STATES_FULL", "URGENT")
    v.send("instantActions", instant("agv-01", ("c", "clearInstantActions")))
    state = v.state()
    assert state["instantActionStates"] == [
        {"actionId": "c", "actionType": "clearInstantActions", "actionStatus": "FINISHED"}
    ]
    assert state["errors"] == []


def test_initialize_position_confirms_where_the_vehicle_stands() -> None:
    v = OneVehicle()
    p = v.layout.point(v.home)

    def init(action_id: str, kind: str, **parameters: Any) -> Any:
        message = {
            **header("agv-01"),
            "actions": [
                {
                    "actionId": action_id,
                    "actionType": kind,
                    "blockingType": "NONE",
                    "actionParameters": [{"key": k, "value": x} for k, x in parameters.items()],
                }
            ],
        }
        v.send("instantActions", message)
        return v.state()["instantActionStates"][-1]

    here = {"x": p.x, "y": p.y, "theta": 0.0, "mapId": v.layout.name, "lastNodeId": v.home}
    assert init("i1", "initializePosition", **here)["actionStatus"] == "FINISHED"
    assert init("i2", "initPosition", **here)["actionStatus"] == "FINISHED"
    away = dict(here, x=p.x + 5.0)
    assert init("i3", "initializePosition", **away)["actionStatus"] == "FAILED"
    assert v.state()["errors"][-1]["errorType"] == "INVALID_INSTANT_ACTION"
    assert init("i4", "initializePosition", x=1.0)["actionStatus"] == "FAILED"
    assert v.state()["lastNodeId"] == v.home


def test_states_keep_the_minimum_interval_and_the_factsheet_says_so() -> None:
    v = OneVehicle()
    sent: list[float] = []
    path = transport_points(v)
    v.send("order", make_order(v.layout, "agv-01", path))
    t = 0.0
    for k in range(400):
        t += 0.01
        if k % 3 == 0:
            out = v.endpoint.handle(
                "instantActions",
                b'{"headerId":0,"timestamp":"2026-01-01T00:00:00.000Z","version":"3.0.0",'
                b'"manufacturer":"ObjectPlaces","serialNumber":"agv-01","actions":[{"actionId":"'
                + f"r{k}".encode()
                + b'","actionType":"stateRequest","blockingType":"NONE"}]}',
                now=t,
            )
            sent += [t for o in out if o.subtopic == "state"]
        v.agv.step(0.01)
        sent += [t for o in v.endpoint.due(t) if o.subtopic == "state"]
    gaps = [b - a for a, b in itertools.pairwise(sent)]
    assert min(gaps) >= MIN_STATE_INTERVAL_S - 1e-9
    assert max(gaps) <= 1.0 + 1e-9
    factsheet = v.endpoint.factsheet()
    assert (factsheet.qos, factsheet.retain) == (0, True)
    sheet = factsheet.message
    assert schema_errors("factsheet", sheet) == []
    limits = sheet["protocolLimits"]
    assert limits["timing"]["minimumStateInterval"] == MIN_STATE_INTERVAL_S
    assert limits["timing"]["defaultStateInterval"] == 1.0
    assert 0 not in limits["maximumArrayLengths"].values()
    optional = {p["parameter"] for p in sheet["protocolFeatures"]["optionalParameters"]}
    assert "order.nodes.nodePosition" in optional
    offered = {a["actionType"]: a for a in sheet["protocolFeatures"]["mobileRobotActions"]}
    assert set(offered) == set(CATALOGUE)
    assert {"cancelOrder", "startPause", "stopPause"} <= set(offered)
    assert offered["pick"]["actionScopes"] == ["NODE"]
    assert sheet["loadSpecification"]["loadPositions"] == ["carrier"]
