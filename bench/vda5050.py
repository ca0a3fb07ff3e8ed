"""VDA 5050 over MQTT: round trips through a local mosquitto, with and without TCP_NODELAY.

Two round trips, each with TCP_NODELAY on (broker ``set_tcp_nodelay true`` and the
clients' sockets, as the bridge runs) and off, over a plain loopback listener (asked
for by name: ``insecure``; the fleet's own links are mutual TLS):

- QoS 1 publish: from ``publish`` to the broker's PUBACK, one message at a time.
- stateRequest to state: a master control publishes ``instantActions`` with a
  ``stateRequest`` to one vehicle's bridge (an order-driven AGV on a simulated node, in
  this process) and waits for the ``state`` that lists that action. The requests go
  ``_REQUEST_GAP_S`` apart, more than the vehicle's ``minimumStateInterval``: a state
  asked for sooner after the last one waits until that interval has passed.

And transport orders from an outside master control (``vda5050-sdk``,
tests/vda5050/outside.py) over mutual TLS, as the fleet runs: 20 orders, each a pick at
one station and a drop at another, to 4 simulated vehicles (5 each, one after the
other), the fleet at 20 times real time: how many finished, the errors the vehicles
reported, the messages that failed their 3.0 schema either way, and the time taken.

Run: .venv/bin/python -m bench.vda5050 [--samples 100]
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import aiomqtt

from agv_app.vda5050.bridge import run_bridge
from agv_app.vda5050.broker import BROKER_ID, LocalBroker, find_mosquitto
from agv_app.vda5050.demo import MASTER_ID
from agv_app.vda5050.endpoint import MIN_STATE_INTERVAL_S, VdaEndpoint
from agv_app.vda5050.link import VdaCredentials, mqtt_link
from agv_app.vda5050.sim_fleet import VdaSimFleet
from agv_app.vda5050.topics import MANUFACTURER, BrokerAddress, VehicleTopics
from bench.report import markdown_table, publish
from objectplaces.security import TemporaryPki
from tests.vda5050.harness import OneVehicle, instant
from tests.vda5050.outside import (
    CheckedTransport,
    Figures,
    carry,
    errors_seen,
    master_client,
    station_pairs,
)
from tests.waiting import until

_WAIT_S = 5.0
_REQUEST_GAP_S = 0.1
_HOST = "127.0.0.1"
_SPEED = 20.0
_STEP_S = 0.05


def _client(broker: BrokerAddress, nodelay: bool) -> aiomqtt.Client:
    return mqtt_link(broker, insecure=True).client(tcp_nodelay=nodelay)


async def qos1_round_trips(broker: BrokerAddress, nodelay: bool, samples: int) -> list[float]:
    """Milliseconds from publish to PUBACK, one QoS 1 message at a time."""
    out = []
    async with _client(broker, nodelay) as client:
        for k in range(samples):
            t0 = time.perf_counter()
            await client.publish("bench/qos1", str(k).encode(), qos=1)
            out.append((time.perf_counter() - t0) * 1000)
    return out


async def state_request_round_trips(
    broker: BrokerAddress, nodelay: bool, samples: int
) -> list[float]:
    """Milliseconds from publishing a stateRequest to receiving the state that lists it."""
    vehicle = OneVehicle()
    topics = VehicleTopics(MANUFACTURER, "agv-01")
    endpoint = VdaEndpoint(vehicle.agv, topics)
    bridge = asyncio.get_running_loop().create_task(
        run_bridge(endpoint, mqtt_link(broker, insecure=True), tcp_nodelay=nodelay)
    )
    out: list[float] = []
    try:
        async with _client(broker, nodelay) as master:
            await master.subscribe(topics.topic("state"), qos=0)
            await asyncio.sleep(0.5)  # the bridge has connected and subscribed
            for k in range(samples):
                await asyncio.sleep(_REQUEST_GAP_S)
                action = f"req-{k}"
                payload = json.dumps(instant("agv-01", (action, "stateRequest"))).encode()
                t0 = time.perf_counter()
                await master.publish(topics.topic("instantActions"), payload, qos=0)
                async with asyncio.timeout(_WAIT_S):
                    async for message in master.messages:
                        body = message.payload if isinstance(message.payload, bytes) else b""
                        states = json.loads(body).get("instantActionStates", [])
                        if any(a["actionId"] == action for a in states):
                            break
                out.append((time.perf_counter() - t0) * 1000)
    finally:
        bridge.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await bridge
    return out


async def transport_orders(agvs: int, per_vehicle: int) -> Figures:
    """``per_vehicle`` transport orders to each of ``agvs`` vehicles from an outside master
    control, over mutual TLS (a throwaway fleet PKI)."""
    with TemporaryPki(fleet="bench") as pki:
        tls = pki.identity(BROKER_ID, role="router", addresses=(_HOST,))
        master = pki.identity(MASTER_ID, role="master")
        with LocalBroker(tls) as broker:
            fleet = VdaSimFleet(
                agvs=agvs, seed=2, vda5050=broker.url, credentials=VdaCredentials(pki)
            )
            transport = CheckedTransport(mqtt_link(broker, tls=master))
            client = master_client(transport)
            traffic = transport.traffic
            await client.connect()
            await fleet.start()

            async def drive() -> None:
                while True:
                    fleet.advance(_STEP_S * _SPEED)
                    await asyncio.sleep(_STEP_S)

            driver = asyncio.get_running_loop().create_task(drive())
            try:
                serials = sorted(fleet.endpoints)
                await until(lambda: all(traffic.last_state(s) for s in serials), within=60)
                t0, sim0 = time.perf_counter(), fleet.now
                async with asyncio.TaskGroup() as tg:
                    runs = [
                        tg.create_task(
                            carry(
                                client,
                                traffic,
                                fleet.layout,
                                serial,
                                station_pairs(i, per_vehicle),
                                within=600,
                            )
                        )
                        for i, serial in enumerate(serials)
                    ]
                wall, sim = time.perf_counter() - t0, fleet.now - sim0
            finally:
                driver.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await driver
                await fleet.stop()
                await client.disconnect()
    return Figures(
        orders=agvs * per_vehicle,
        finished=sum(r.result() for r in runs),
        errors=errors_seen(traffic),
        schema_failures=len(traffic.schema_failures),
        wall_s=wall,
        sim_s=sim,
    )


def _summary(values: list[float]) -> tuple[str, str, str]:
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return (f"{statistics.median(values):.2f}", f"{p95:.2f}", f"{max(values):.2f}")


async def _run(samples: int) -> tuple[list[list[object]], Figures]:
    rows: list[list[object]] = []
    for nodelay in (True, False):
        with LocalBroker(insecure=True, tcp_nodelay=nodelay) as broker:
            qos1 = await qos1_round_trips(broker, nodelay, samples)
            request = await state_request_round_trips(broker, nodelay, samples)
        label = "on" if nodelay else "off"
        rows.append([label, "QoS 1 publish to PUBACK", samples, *_summary(qos1)])
        rows.append([label, "stateRequest to state", samples, *_summary(request)])
    return rows, await transport_orders(4, 5)


def main(argv: list[str] | None = None) -> int:
    """Measure and record the section ``vda5050`` of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=100, help="round trips per figure")
    args = parser.parse_args(argv)
    if find_mosquitto() is None:
        print("mosquitto is not installed (make mosquitto)", file=sys.stderr)
        return 1
    rows, figures = asyncio.run(_run(args.samples))
    transport = [
        [
            f"{figures.orders} to 4 vehicles",
            figures.finished,
            figures.errors,
            figures.schema_failures,
            f"{figures.wall_s:.1f}",
            f"{figures.sim_s:.0f}",
        ]
    ]
    body = (
        "Loopback, a mosquitto started for the run (`agv_app/vda5050/broker.py`), the "
        "clients on `aiomqtt`. TCP_NODELAY on: the broker's `set_tcp_nodelay true` and "
        "the clients' sockets, as the bridge runs; off: neither. State requests "
        f"{_REQUEST_GAP_S:g} s apart (the vehicle keeps {MIN_STATE_INTERVAL_S:g} s between "
        "two states). Milliseconds.\n\n"
        + markdown_table(["TCP_NODELAY", "round trip", "samples", "median", "p95", "max"], rows)
        + "\n\nTransport orders from an outside master control (`vda5050-sdk`), each a pick "
        "at one station and a drop at another, over mutual TLS; the simulated fleet at "
        f"{_SPEED:g} times real time. Errors: distinct entries in the vehicles' states; "
        "schema failures: messages either way against the 3.0 schemas.\n\n"
        + markdown_table(
            ["transport orders", "finished", "errors", "schema failures", "wall s", "simulated s"],
            transport,
        )
    )
    publish(
        "vda5050",
        "VDA 5050 over MQTT: round trips (bench/vda5050.py)",
        body,
        f".venv/bin/python -m bench.vda5050 --samples {args.samples}",
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
