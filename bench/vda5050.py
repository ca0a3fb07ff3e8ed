"""VDA 5050 over MQTT: round trips through a local mosquitto, with and without TCP_NODELAY.

Two figures, each with TCP_NODELAY on (broker ``set_tcp_nodelay true`` and the clients'
sockets, as the bridge runs) and off, over a plain loopback listener (asked for by name:
``insecure``; the fleet's own links are mutual TLS):

- QoS 1 publish: from ``publish`` to the broker's PUBACK, one message at a time.
- stateRequest to state: a master control publishes ``instantActions`` with a
  ``stateRequest`` to one vehicle's bridge (an order-driven AGV on a simulated node, in
  this process) and waits for the ``state`` that lists that action.

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
from agv_app.vda5050.broker import LocalBroker, find_mosquitto
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.link import mqtt_link
from agv_app.vda5050.topics import MANUFACTURER, BrokerAddress, VehicleTopics
from bench.report import markdown_table, publish
from tests.vda5050.harness import OneVehicle, instant

_WAIT_S = 5.0


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


def _summary(values: list[float]) -> tuple[str, str, str]:
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return (f"{statistics.median(values):.2f}", f"{p95:.2f}", f"{max(values):.2f}")


async def _run(samples: int) -> list[list[object]]:
    rows: list[list[object]] = []
    for nodelay in (True, False):
        with LocalBroker(insecure=True, tcp_nodelay=nodelay) as broker:
            qos1 = await qos1_round_trips(broker, nodelay, samples)
            request = await state_request_round_trips(broker, nodelay, samples)
        label = "on" if nodelay else "off"
        rows.append([label, "QoS 1 publish to PUBACK", samples, *_summary(qos1)])
        rows.append([label, "stateRequest to state", samples, *_summary(request)])
    return rows


def main(argv: list[str] | None = None) -> int:
    """Measure and record the section ``vda5050`` of BENCHMARKS.md."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--samples", type=int, default=100, help="round trips per figure")
    args = parser.parse_args(argv)
    if find_mosquitto() is None:
        print("mosquitto is not installed (make mosquitto)", file=sys.stderr)
        return 1
    rows = asyncio.run(_run(args.samples))
    body = (
        "Loopback, a mosquitto started for the run (`agv_app/vda5050/broker.py`), the "
        "clients on `aiomqtt`. TCP_NODELAY on: the broker's `set_tcp_nodelay true` and "
        "the clients' sockets, as the bridge runs; off: neither. Milliseconds.\n\n"
        + markdown_table(["TCP_NODELAY", "round trip", "samples", "median", "p95", "max"], rows)
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
