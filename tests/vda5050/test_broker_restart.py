"""The broker restarted under a running fleet: every vehicle's client connects again by
itself, says ``ONLINE`` and republishes its factsheet (the new broker has no retained
message), reports state again and takes an order given through the new broker.

Real processes on 127.0.0.1: mosquitto with the fleet's PKI, AGV processes on the mesh
each with a VDA 5050 bridge, a probe as master control.
"""

from __future__ import annotations

import pytest

from agv_app.fleet import MeshFleet
from agv_app.layout.demo import demo_warehouse
from agv_app.vda5050.broker import BROKER_ID, LocalBroker, find_mosquitto
from agv_app.vda5050.demo import MASTER_ID
from agv_app.vda5050.link import VdaCredentials, mqtt_link
from objectplaces.security import TemporaryPki
from tests.vda5050.harness import make_order
from tests.vda5050.probe import Probe, probe

pytestmark = [pytest.mark.processes, pytest.mark.slow]

AGVS = ["agv-01", "agv-02"]
LAYOUT = demo_warehouse()


def _online(p: Probe, serial: str) -> bool:
    said = p.of(serial, "connection")
    return bool(said) and said[-1].message["connectionState"] == "ONLINE"


async def test_vehicles_come_back_by_themselves_when_the_broker_restarts(
    pki: TemporaryPki, credentials: VdaCredentials
) -> None:
    if find_mosquitto() is None:
        pytest.fail("mosquitto is not installed: make mosquitto")
    identity = pki.identity(BROKER_ID, role="router")
    first = LocalBroker(identity)
    address = first.start()
    fleet = MeshFleet(
        agvs=2,
        seed=3,
        task_interval=None,
        run_seconds=150.0,
        vda5050=address.url,
        vda5050_credentials=credentials,
    )
    master = mqtt_link(address, tls=pki.identity(MASTER_ID, role="master"))
    second = LocalBroker(identity, port=address.port)
    try:
        await fleet.start()
        async with probe(master) as before:
            await before.wait_for(
                lambda: all(len(before.of(a, "state")) >= 2 for a in AGVS),
                within=60,
                why="states before the restart",
            )
        first.stop()
        await before.wait_for(
            lambda: fleet.metrics()["vda5050_broker_connected"] == 0.0,
            within=30,
            why="the fleet noticing the broker gone",
        )
        second.start()
        async with probe(master) as after:
            await after.wait_for(
                lambda: all(_online(after, a) and after.of(a, "factsheet") for a in AGVS),
                within=60,
                why=lambda: f"ONLINE, a factsheet: {[s.message for s in after.seen]}",
            )
            await after.wait_for(
                lambda: all(len(after.of(a, "state")) >= 2 for a in AGVS),
                within=30,
                why="states after the restart",
            )
            start = after.last_state("agv-01")["lastNodeId"]
            path = list(LAYOUT.shortest_path(start, LAYOUT.station("pick-A3-1").point))
            await after.send("agv-01", "order", make_order(LAYOUT, "agv-01", path))

            def finished() -> bool:
                state = after.last_state("agv-01")
                return (
                    state.get("orderId") == "order-1"
                    and state["nodeStates"] == []
                    and not state["driving"]
                )

            await after.wait_for(finished, within=90, why="the order given after the restart")
            assert after.last_state("agv-01")["lastNodeId"] == path[-1]
            assert after.last_state("agv-01")["errors"] == []
        assert fleet.metrics()["vda5050_broker_connected"] == 1.0
        assert fleet.metrics()["collisions"] == 0
    finally:
        await fleet.stop()
        first.stop()
        second.stop()
