"""The simulated fleet speaking VDA 5050 from this process: one client per AGV, mosquitto,
every client with its own certificate, the test as the master control."""

from __future__ import annotations

import asyncio
import contextlib

import pytest

from agv_app.vda5050.link import MqttLink, VdaCredentials
from agv_app.vda5050.sim_fleet import VdaSimFleet
from agv_app.vda5050.topics import BrokerAddress
from agv_app.vda5050.validation import schema_errors
from tests.vda5050.harness import DT, make_order
from tests.vda5050.probe import probe, state_gaps

pytestmark = pytest.mark.slow

AGVS = ["agv-01", "agv-02"]


async def drive(fleet: VdaSimFleet) -> None:
    """Advance the fleet in about real time, as the dashboard's driver does."""
    while True:
        fleet.advance(DT)
        await asyncio.sleep(DT)


async def test_every_simulated_agv_speaks_and_drives_an_order(
    broker: BrokerAddress, credentials: VdaCredentials, master: MqttLink
) -> None:
    assert broker.url.startswith("mqtts://")
    fleet = VdaSimFleet(agvs=2, seed=4, vda5050=broker.url, credentials=credentials)
    async with probe(master) as p:
        await fleet.start()
        driver = asyncio.get_running_loop().create_task(drive(fleet))
        try:
            await p.wait_for(
                lambda: all(len(p.of(a, "state")) >= 4 for a in AGVS), within=30, why="states"
            )
            for a in AGVS:
                states = p.of(a, "state")
                assert all(schema_errors("state", s.message) == [] for s in states)
                gaps = state_gaps(states)
                assert max(gaps) <= 1.5, gaps
                assert p.of(a, "connection")[-1].message["connectionState"] == "ONLINE"
                assert schema_errors("factsheet", p.of(a, "factsheet")[-1].message) == []
            await p.wait_for(
                lambda: fleet.metrics()["vda5050_vehicles_online"] == 2.0,
                within=30,
                why="the monitor sees both vehicles online",
            )
            start = fleet.agvs["agv-02"].point
            station = fleet.layout.station("pick-A3-1").point
            path = list(fleet.layout.shortest_path(start, station))[:12]
            await p.send("agv-02", "order", make_order(fleet.layout, "agv-02", path))
            await p.wait_for(
                lambda: (
                    p.last_state("agv-02")["orderId"] == "order-1"
                    and p.last_state("agv-02")["nodeStates"] == []
                    and not p.last_state("agv-02")["driving"]
                ),
                within=60,
                why=lambda: f"the order finished: {p.last_state('agv-02')}",
            )
            assert p.last_state("agv-02")["lastNodeId"] == path[-1]
            assert fleet.agvs["agv-02"].point == path[-1]
            assert fleet.metrics()["collisions"] == 0
        finally:
            driver.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await driver
            await fleet.stop()
        await p.wait_for(
            lambda: all(
                p.of(a, "connection")[-1].message["connectionState"] == "OFFLINE" for a in AGVS
            ),
            within=10,
            why=lambda: (
                "OFFLINE after stop: "
                + str(
                    {a: [c.message["connectionState"] for c in p.of(a, "connection")] for a in AGVS}
                )
            ),
        )
