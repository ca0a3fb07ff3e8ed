"""A master control's transport orders in the fleet's task book and on the dashboard's
``/api/tasks``, as orders of the master (the simulated fleet, no broker needed)."""

from __future__ import annotations

import json
from typing import Any

from agv_app.vda5050.link import VdaCredentials
from agv_app.vda5050.sim_fleet import VdaSimFleet
from dashboard.app import create_app
from tests.dashboard.login import logged_in
from tests.vda5050.harness import action, instant, make_order


def fleet() -> VdaSimFleet:
    return VdaSimFleet(
        agvs=2,
        seed=3,
        vda5050="mqtt://127.0.0.1:1883",
        credentials=VdaCredentials(insecure=True),
    )


def send(f: VdaSimFleet, serial: str, subtopic: str, message: Any) -> None:
    f.endpoints[serial].handle(subtopic, json.dumps(message).encode(), now=f.now)


def transport(f: VdaSimFleet, serial: str, order_id: str) -> dict[str, Any]:
    layout, home = f.layout, f.agvs[serial].point
    a, b = layout.station("pick-A3-1").point, layout.station("drop-A4-3").point
    legs = [layout.shortest_path(home, a), layout.shortest_path(a, b)]
    points = [*legs[0], *legs[1][1:]]
    actions = {
        len(legs[0]) - 1: [action(f"{order_id}-p", "pick")],
        len(points) - 1: [action(f"{order_id}-d", "drop")],
    }
    return make_order(layout, serial, points, order_id=order_id, actions=actions)


def test_a_transport_order_shows_as_an_order_of_the_master_until_done() -> None:
    f = fleet()
    client = logged_in(create_app(f))
    send(f, "agv-01", "order", transport(f, "agv-01", "m-1"))
    send(f, "agv-02", "order", make_order(f.layout, "agv-02", [f.agvs["agv-02"].point]))
    (shown,) = client.get("/api/tasks").json()
    assert shown["id"] == "m-1"
    assert shown["creator"] == "master"
    assert (shown["source"], shown["destination"]) == ("pick-A3-1", "drop-A4-3")
    assert (shown["state"], shown["vehicle"]) == ("driving", "agv-01")
    tasks = {v["id"]: v["task"] for v in client.get("/api/vehicles").json()}
    assert tasks == {"agv-01": "m-1", "agv-02": None}
    for _ in range(6000):
        f.step()
        if not f.agvs["agv-01"].book_of_orders.active:  # type: ignore[attr-defined]
            break
    (shown,) = client.get("/api/tasks").json()
    assert shown["state"] == "done"
    assert f.metrics()["collisions"] == 0


def test_a_cancelled_transport_order_shows_cancelled() -> None:
    f = fleet()
    client = logged_in(create_app(f))
    send(f, "agv-02", "order", transport(f, "agv-02", "m-2"))
    f.run(5.0)
    send(f, "agv-02", "instantActions", instant("agv-02", ("c", "cancelOrder")))
    for _ in range(3000):
        f.step()
        if not f.agvs["agv-02"].book_of_orders.active:  # type: ignore[attr-defined]
            break
    (shown,) = client.get("/api/tasks").json()
    assert (shown["creator"], shown["state"]) == ("master", "cancelled")
    r = client.delete("/api/tasks/m-2")
    assert r.status_code == 409
