"""Topic names, broker addresses, and the broker monitor's figures (fake clock)."""

from __future__ import annotations

import asyncio
import contextlib
import json

import pytest

from agv_app.vda5050.bridge import honour_cancellation
from agv_app.vda5050.link import MqttLink
from agv_app.vda5050.monitor import BrokerMonitor
from agv_app.vda5050.topics import BrokerAddress, VehicleTopics, fleet_filter, parse_broker_url


def test_topics_follow_the_spec() -> None:
    topics = VehicleTopics("ObjectPlaces", "agv-07")
    assert topics.topic("state") == "uagv/v3/ObjectPlaces/agv-07/state"
    assert topics.topic("instantActions") == "uagv/v3/ObjectPlaces/agv-07/instantActions"
    assert fleet_filter() == "uagv/v3/+/+/#"
    with pytest.raises(ValueError, match="subtopic"):
        topics.topic("zoneSet")
    for bad in ("", "a/b", "x+", "#"):
        with pytest.raises(ValueError, match="topic level"):
            VehicleTopics("ObjectPlaces", bad)


def test_broker_urls() -> None:
    assert parse_broker_url("mqtts://127.0.0.1:1884") == BrokerAddress("127.0.0.1", 1884)
    assert parse_broker_url("mqtts://broker.local") == BrokerAddress("broker.local", 8883)
    assert parse_broker_url("mqtt://127.0.0.1:1884") == BrokerAddress("127.0.0.1", 1884, tls=False)
    assert parse_broker_url("mqtt://broker.local").port == 1883
    assert BrokerAddress("127.0.0.1", 1884).url == "mqtts://127.0.0.1:1884"
    assert BrokerAddress("127.0.0.1", 1884, tls=False).url == "mqtt://127.0.0.1:1884"
    assert BrokerAddress("::1", 8883).url == "mqtts://[::1]:8883"
    assert parse_broker_url("mqtts://[::1]:8883") == BrokerAddress("::1", 8883)
    for bad in ("tcp://127.0.0.1:1883", "mqtts://:1883", "mqtt://h:70000", "127.0.0.1:1883"):
        with pytest.raises(ValueError, match=r"broker address|port"):
            parse_broker_url(bad)


def test_the_monitor_counts_messages_per_second_and_connection_states() -> None:
    now = [100.0]
    monitor = BrokerMonitor(MqttLink(BrokerAddress("127.0.0.1", 1)), clock=lambda: now[0])
    state = json.dumps({"connectionState": "ONLINE"}).encode()
    for serial in ("agv-01", "agv-02"):
        monitor.seen(f"uagv/v3/ObjectPlaces/{serial}/connection", state)
    for _ in range(8):
        monitor.seen("uagv/v3/ObjectPlaces/agv-01/state", b"{}")
    broken = json.dumps({"connectionState": "CONNECTION_BROKEN"}).encode()
    monitor.seen("uagv/v3/ObjectPlaces/agv-02/connection", broken)
    monitor.seen("uagv/v3/ObjectPlaces/agv-02/connection", b"not json")
    status = monitor.status()
    assert status["vda5050_messages"] == 12
    assert status["vda5050_messages_per_s"] == pytest.approx(12 / 5)
    assert status["vda5050_vehicles_online"] == 1
    assert status["vda5050_broker_connected"] == 0
    now[0] += 6.0
    assert monitor.messages_per_s() == 0.0
    assert monitor.connection_states == {"agv-01": "ONLINE", "agv-02": "CONNECTION_BROKEN"}


async def test_a_swallowed_cancellation_is_still_honoured() -> None:
    async def body() -> None:
        with contextlib.suppress(asyncio.CancelledError):
            await asyncio.sleep(10)  # swallowed, as Python 3.11's wait_for can
        honour_cancellation()
        await asyncio.sleep(10)

    task = asyncio.get_running_loop().create_task(body())
    await asyncio.sleep(0)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await asyncio.wait_for(task, 5)
