"""The VDA 5050 bridge end to end: mosquitto, AGV processes on the mesh, a probe as master.

Real processes on 127.0.0.1; one fleet PKI for the mesh and the broker (every AGV
process holds one certificate for both); every wait is bounded, and every child is
reaped.
"""

from __future__ import annotations

import os
import signal

import pytest

from agv_app.fleet import MeshFleet
from agv_app.layout.demo import demo_warehouse
from agv_app.vda5050.link import MqttLink, VdaCredentials
from agv_app.vda5050.topics import BrokerAddress
from agv_app.vda5050.validation import schema_errors
from tests.vda5050.harness import instant, make_order
from tests.vda5050.probe import Probe, probe, state_gaps

pytestmark = [pytest.mark.processes, pytest.mark.slow]

AGVS = ["agv-01", "agv-02"]
LAYOUT = demo_warehouse()


def station_path(p: Probe, serial: str) -> list[str]:
    """The shortest path from where ``serial`` stands to pick station A3-1."""
    start = p.last_state(serial)["lastNodeId"]
    return list(LAYOUT.shortest_path(start, LAYOUT.station("pick-A3-1").point))


def far_path(p: Probe, serial: str) -> list[str]:
    """The shortest path from where ``serial`` stands to the station farthest from it."""
    start = p.last_state(serial)["lastNodeId"]
    ends = [LAYOUT.station(s).point for s in LAYOUT.usable_stations()]
    far = max(ends, key=lambda e: (LAYOUT.distance(start, e), e))
    return list(LAYOUT.shortest_path(start, far))


async def started_fleet(broker: BrokerAddress, credentials: VdaCredentials) -> MeshFleet:
    fleet = MeshFleet(
        agvs=2,
        seed=3,
        task_interval=None,
        run_seconds=100.0,
        vda5050=broker.url,
        vda5050_credentials=credentials,
    )
    await fleet.start()
    return fleet


async def test_every_agv_publishes_valid_messages_and_drives_an_order(
    broker: BrokerAddress, credentials: VdaCredentials, master: MqttLink
) -> None:
    async with probe(master) as p:
        fleet = await started_fleet(broker, credentials)
        try:
            await p.wait_for(
                lambda: all(len(p.of(a, "state")) >= 5 for a in AGVS), within=40, why="states"
            )
            for a in AGVS:
                states = p.of(a, "state")
                for s in states:
                    assert schema_errors("state", s.message) == []
                gaps = state_gaps(states)
                assert max(gaps) <= 1.5, f"{a} states at >= 1 Hz, gaps {gaps}"
                ids = [s.message["headerId"] for s in states]
                assert ids == sorted(set(ids))
                (online,) = [c for c in p.of(a, "connection") if c.message["connectionState"]]
                assert online.message["connectionState"] == "ONLINE"
                assert schema_errors("connection", online.message) == []
                (factsheet,) = p.of(a, "factsheet")
                assert schema_errors("factsheet", factsheet.message) == []
                visualizations = p.of(a, "visualization")
                assert visualizations
                assert schema_errors("visualization", visualizations[-1].message) == []
            metrics = fleet.metrics()
            assert metrics["vda5050_broker_connected"] == 1.0
            assert metrics["vda5050_messages_per_s"] > 2.0
            assert metrics["vda5050_vehicles_online"] == 2.0

            path = station_path(p, "agv-01")
            await p.send("agv-01", "order", make_order(LAYOUT, "agv-01", path))
            counts: list[int] = []

            def finished() -> bool:
                state = p.last_state("agv-01")
                if state.get("orderId") != "order-1":
                    return False
                n = len(state["nodeStates"])
                if not counts or counts[-1] != n:
                    counts.append(n)
                return n == 0 and not state["driving"]

            await p.wait_for(finished, within=60, why="the order finished")
            assert counts[0] == len(path) - 1
            assert counts == sorted(counts, reverse=True)
            assert len(counts) >= 3, f"nodeStates shrink step by step: {counts}"
            final = p.last_state("agv-01")
            assert final["lastNodeId"] == path[-1]
            assert final["errors"] == []
            await p.wait_for(
                lambda: next(v for v in fleet.vehicles() if v.id == "agv-01").status == "idle",
                within=10,
                why="agv-01 idle",
            )
            assert fleet.metrics()["collisions"] == 0
        finally:
            await fleet.stop()
        await p.wait_for(
            lambda: all(
                p.of(a, "connection")[-1].message["connectionState"] == "OFFLINE" for a in AGVS
            ),
            within=10,
            why="OFFLINE on a graceful stop",
        )


async def test_bad_orders_are_reported_cancel_stops_and_a_killed_agv_breaks(
    broker: BrokerAddress, credentials: VdaCredentials, master: MqttLink
) -> None:
    async with probe(master) as p:
        fleet = await started_fleet(broker, credentials)
        try:
            await p.wait_for(
                lambda: all(p.last_state(a) for a in AGVS), within=40, why="first states"
            )
            await p.send("agv-02", "order", b"{broken")
            bad = make_order(LAYOUT, "agv-02", station_path(p, "agv-02"))
            bad["nodes"][-1]["nodeId"] = "nowhere"
            await p.send("agv-02", "order", bad)
            await p.wait_for(
                lambda: len(p.last_state("agv-02")["errors"]) == 2,
                within=10,
                why=lambda: f"two errors: {p.last_state('agv-02')['errors']}",
            )
            errors = p.last_state("agv-02")["errors"]
            assert [e["errorType"] for e in errors] == ["VALIDATION_FAILURE", "NO_ROUTE_TO_TARGET"]
            assert schema_errors("state", p.last_state("agv-02")) == []

            path = station_path(p, "agv-02")
            await p.send("agv-02", "order", make_order(LAYOUT, "agv-02", path, order_id="o-2"))
            await p.wait_for(
                lambda: (
                    p.last_state("agv-02")["orderId"] == "o-2"
                    and len(p.last_state("agv-02")["nodeStates"]) <= len(path) - 3
                ),
                within=40,
                why="agv-02 under way after the bad orders",
            )
            assert p.last_state("agv-02")["errors"] == []
            await p.send("agv-02", "instantActions", instant("agv-02", ("stop", "cancelOrder")))
            await p.wait_for(
                lambda: (
                    p.last_state("agv-02")["nodeStates"] == []
                    and not p.last_state("agv-02")["driving"]
                    and p.last_state("agv-02")["instantActionStates"][-1]["actionStatus"]
                    == "FINISHED"
                ),
                within=20,
                why="the cancelled order stopped",
            )
            stopped = p.last_state("agv-02")
            assert stopped["lastNodeId"] in path[:-1], "stopped before the order's end"
            assert fleet.metrics()["collisions"] == 0

            pid = fleet.pids()[AGVS.index("agv-01")]
            os.kill(pid, signal.SIGKILL)
            await p.wait_for(
                lambda: (
                    p.of("agv-01", "connection")[-1].message["connectionState"]
                    == "CONNECTION_BROKEN"
                ),
                within=10,
                why="the last will",
            )
            assert schema_errors("connection", p.of("agv-01", "connection")[-1].message) == []
            before = len(p.of("agv-02", "state"))
            await p.wait_for(
                lambda: len(p.of("agv-02", "state")) >= before + 2, within=10, why="agv-02 alive"
            )
        finally:
            await fleet.stop()
