"""An outside master control (``vda5050-sdk``, tests/vda5050/outside.py) drives the simulated
fleet over mosquitto: transport orders with pick and drop across two stations, instant
actions, every message checked against the 3.0 schemas both ways."""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import pytest
from vda5050 import Action, BlockingType, MasterClient

from agv_app.vda5050.link import MqttLink, VdaCredentials
from agv_app.vda5050.sim_fleet import VdaSimFleet
from agv_app.vda5050.topics import BrokerAddress
from tests.vda5050.outside import (
    CheckedTransport,
    Traffic,
    carry,
    dispatch_in_turn,
    errors_seen,
    finished,
    master_client,
    station_pairs,
    target,
    transport_order,
)
from tests.waiting import until

pytestmark = pytest.mark.slow

SPEED = 10.0  # simulated seconds per wall second
STEP_S = 0.05


async def drive(fleet: VdaSimFleet, speed: float) -> None:
    """Advance the fleet ``speed`` times faster than real time, as the dashboard does."""
    while True:
        fleet.advance(STEP_S * speed)
        await asyncio.sleep(STEP_S)


@asynccontextmanager
async def running(
    fleet: VdaSimFleet, master: MqttLink, *, speed: float = SPEED
) -> AsyncIterator[tuple[MasterClient, Traffic]]:
    """The fleet's bridges, its driver and the outside master, all stopped after."""
    transport = CheckedTransport(master)
    client = master_client(transport)
    await client.connect()
    await fleet.start()
    driver = asyncio.get_running_loop().create_task(drive(fleet, speed))
    try:
        serials = list(fleet.endpoints)
        await until(lambda: all(transport.traffic.last_state(s) for s in serials), within=60)
        await until(lambda: all(transport.traffic.of(s, "factsheet") for s in serials), within=60)
        yield client, transport.traffic
    finally:
        driver.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await driver
        await fleet.stop()
        await client.disconnect()


async def test_an_outside_master_has_a_load_carried_from_one_station_to_another(
    broker: BrokerAddress, credentials: VdaCredentials, master: MqttLink
) -> None:
    fleet = VdaSimFleet(agvs=2, seed=5, vda5050=broker.url, credentials=credentials)
    async with running(fleet, master) as (client, traffic):
        serial = "agv-02"
        home = traffic.last_state(serial)["lastNodeId"]
        order = transport_order(
            fleet.layout,
            serial,
            "transport-1",
            start=home,
            pick="pick-A2-1",
            drop="drop-A5-3",
            end=home,
            load_id="pallet-7",
        )
        await dispatch_in_turn(client, traffic, serial, order)
        await until(lambda: finished(traffic, serial, "transport-1"), within=240)
        states = traffic.of(serial, "state")
        loads = [s["loads"] for s in states if s["orderId"] == "transport-1"]
        assert [{"loadId": "pallet-7"}] in loads, "carried between the stations"
        assert loads[-1] == []
        final = states[-1]
        assert {a["actionId"]: a["actionStatus"] for a in final["actionStates"]} == {
            "transport-1-pick": "FINISHED",
            "transport-1-drop": "FINISHED",
        }
        assert final["lastNodeId"] == home
        assert all(s["errors"] == [] for s in states)
        session = await client.session(target(serial))
        assert not session.is_busy, "the client sees the vehicle idle again"
        # A second order from where it stands, which the client's own acceptance
        # policy lets go only once it has seen the first one finish.
        again = transport_order(
            fleet.layout,
            serial,
            "transport-2",
            start=home,
            pick="pickdrop-A5-2",
            drop="drop-A2-3",
            end=home,
            load_id="pallet-8",
        )
        await dispatch_in_turn(client, traffic, serial, again[:1])
        await until(lambda: traffic.last_state(serial).get("orderId") == "transport-2", within=30)
        await client.pause(target(serial))
        await until(lambda: traffic.last_state(serial).get("paused") is True, within=30)
        await client.resume(target(serial))
        await client.cancel_order(target(serial))
        await until(lambda: finished(traffic, serial, "transport-2"), within=120)
        await client.request_factsheet(target(serial))
        await until(lambda: len(traffic.of(serial, "factsheet")) >= 2, within=30)
        await client.send_instant_action(target(serial), [_clear()])
        await until(
            lambda: (
                [a["actionType"] for a in traffic.last_state(serial)["instantActionStates"]]
                == ["clearInstantActions"]
            ),
            within=30,
        )
    kinds = {subtopic for subtopic, _ in traffic.sent}
    assert kinds == {"order", "instantActions"}
    assert traffic.schema_failures == []
    assert fleet.metrics()["collisions"] == 0


def _clear() -> Action:
    return Action(
        action_id="clear-1", action_type="clearInstantActions", blocking_type=BlockingType.NONE
    )


async def test_twenty_transport_orders_to_four_vehicles_all_finish(
    broker: BrokerAddress, credentials: VdaCredentials, master: MqttLink
) -> None:
    fleet = VdaSimFleet(agvs=4, seed=2, vda5050=broker.url, credentials=credentials)
    async with running(fleet, master, speed=20.0) as (client, traffic):
        serials = sorted(fleet.endpoints)
        async with asyncio.TaskGroup() as tg:
            runs = [
                tg.create_task(
                    carry(client, traffic, fleet.layout, s, station_pairs(i, 5), within=600)
                )
                for i, s in enumerate(serials)
            ]
        assert [r.result() for r in runs] == [5, 5, 5, 5]
    assert errors_seen(traffic) == 0
    assert traffic.schema_failures == []
    assert fleet.metrics()["collisions"] == 0
    assert fleet.metrics()["lock_overlaps"] == 0
