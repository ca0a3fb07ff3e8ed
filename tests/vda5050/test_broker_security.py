"""The broker against attackers: mosquitto on 127.0.0.1 as the project configures it, with
certificates made by the test (``conftest.py``), real vehicle bridges, the test as the
master control.

A refused publication is silent in MQTT 3.1.1 (the broker acknowledges it and drops it),
so every "never arrives" here is shown by order: the attacker's forgery goes first, a
message that is allowed goes after it on the same path, and once that one has arrived
the forgery would have arrived before it.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import socket
import ssl
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from typing import Any

import aiomqtt
import pytest
import trustme

from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.broker import LocalBroker
from agv_app.vda5050.link import BrokerError, MqttLink, mqtt_link, probe_broker
from agv_app.vda5050.monitor import MONITOR_ID
from agv_app.vda5050.topics import MANUFACTURER, BrokerAddress, VehicleTopics
from objectplaces.security import Identity, TemporaryPki, revoke
from tests.vda5050.harness import OneVehicle, instant, make_order
from tests.vda5050.probe import Probe, probe
from tests.waiting import until

pytestmark = [pytest.mark.slow]

WITHIN = 60.0  # seconds: events on a loaded 2-core machine, never a speed


def topic(serial: str, subtopic: str) -> str:
    return VehicleTopics(MANUFACTURER, serial).topic(subtopic)


def link_of(pki: TemporaryPki, broker: BrokerAddress, node_id: str) -> MqttLink:
    return mqtt_link(broker, tls=Identity.from_pki(pki.directory, node_id))


@dataclass
class Vehicle:
    """A vehicle whose bridge runs (its AGV is not stepped: commands still take effect)."""

    one: OneVehicle
    counters: BridgeCounters

    @property
    def state(self) -> dict[str, Any]:
        return self.one.state()


@contextlib.asynccontextmanager
async def vehicle(link: MqttLink, p: Probe | None = None) -> AsyncIterator[Vehicle]:
    """Run the bridge of the vehicle ``link`` names; with ``p``, until it has subscribed."""
    assert link.client_id is not None
    running = Vehicle(OneVehicle(node_id=link.client_id), BridgeCounters())
    task = asyncio.get_running_loop().create_task(
        run_bridge(running.one.endpoint, link, counters=running.counters, retry_s=0.2)
    )
    try:
        if p is not None:
            # Its first state goes out once its SUBACK is in: from then on it hears commands.
            serial = link.client_id
            await p.wait_for(lambda: bool(p.of(serial, "state")), within=WITHIN, why=f"{serial} up")
        yield running
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def answered(p: Probe, serial: str, action_id: str) -> None:
    """Send ``serial`` a stateRequest and wait for the state that lists it."""
    await p.send(serial, "instantActions", instant(serial, (action_id, "stateRequest")))

    def listed() -> bool:
        return any(
            a["actionId"] == action_id
            for s in p.of(serial, "state")
            for a in s.message.get("instantActionStates", [])
        )

    await p.wait_for(listed, within=WITHIN, why=f"{serial} answering {action_id}")


def said(p: Probe, serial: str, message: dict[str, Any]) -> Callable[[], bool]:
    """Whether ``serial`` has published ``message`` as its state."""
    return lambda: any(s.message == message for s in p.of(serial, "state"))


def took_and_paused(p: Probe, serial: str) -> Callable[[], bool]:
    """Whether ``serial``'s last state shows the order named after it, and pausing."""
    return lambda: (
        p.last_state(serial).get("paused") is True and p.last_state(serial)["orderId"] == serial
    )


def mqtt_connect(context: ssl.SSLContext | None, broker: BrokerAddress, client_id: str) -> str:
    """Open a connection and send an MQTT CONNECT; say how the broker answered:
    ``accepted``, the TLS alert it sent, or ``closed`` (blocks; run it in a thread).

    Over TLS 1.3 the broker judges our certificate after our side of the handshake: the
    CONNECT goes out only once it has (session tickets: taken; an alert: refused), or a
    refusal would race it and the alert could be lost to the reset that follows.
    """
    cid = client_id.encode()
    body = b"\x00\x04MQTT\x04\x02\x00\x3c" + len(cid).to_bytes(2, "big") + cid
    packet = b"\x10" + bytes([len(body)]) + body
    with socket.create_connection((broker.host, broker.port), timeout=WITHIN) as raw:
        try:
            if context is None:
                raw.sendall(packet)
                answer = raw.recv(4)
            else:
                with context.wrap_socket(raw, server_hostname=broker.host) as tls:
                    tls.settimeout(0.02)
                    deadline = time.monotonic() + WITHIN
                    while tls.session is None or not tls.session.has_ticket:
                        assert time.monotonic() < deadline, "no verdict on the certificate"
                        with contextlib.suppress(TimeoutError):
                            if not tls.recv(1):
                                return "closed"
                    tls.settimeout(WITHIN)
                    tls.sendall(packet)
                    answer = tls.recv(4)
        except ssl.SSLError as exc:
            return str(exc.reason) if exc.reason else repr(exc)
        except ConnectionError:
            return "closed"
    if answer[:1] == b"\x20":  # CONNACK: return code in its fourth byte
        return "accepted" if answer[3:4] == b"\x00" else f"CONNACK {answer[3:4].hex()}"
    return "closed"


async def connects(context: ssl.SSLContext | None, broker: BrokerAddress, cid: str) -> str:
    return await asyncio.to_thread(mqtt_connect, context, broker, cid)


def trusting(pki: TemporaryPki) -> ssl.SSLContext:
    """A client context that trusts the fleet CA and shows no certificate."""
    context = ssl.create_default_context(cafile=str(pki.directory / "ca.pem"))
    context.minimum_version = ssl.TLSVersion.TLSv1_3
    return context


def attacker(link: MqttLink, *, identifier: str | None = None) -> aiomqtt.Client:
    """A client with ``link``'s certificate that asks for the client id it likes."""
    return aiomqtt.Client(
        link.broker.host, link.broker.port, identifier=identifier, tls_context=link.tls_context()
    )


# -- who may connect ----------------------------------------------------------------------


async def test_only_a_client_with_a_certificate_of_the_fleet_ca_gets_in(
    pki: TemporaryPki, broker: BrokerAddress
) -> None:
    own = link_of(pki, broker, "agv-01").tls_context()
    assert await connects(own, broker, "agv-01") == "accepted"
    assert await connects(trusting(pki), broker, "anyone") == "TLSV13_ALERT_CERTIFICATE_REQUIRED"
    assert await connects(None, broker, "anyone") == "closed"  # no TLS at all

    other_ca = trustme.CA(organization_name="vda5050-tests")
    forged = other_ca.issue_cert("agv-01", common_name="agv-01", organization_unit_name="agv")
    context = trusting(pki)
    forged.configure_cert(context)
    assert await connects(context, broker, "agv-01") == "TLSV1_ALERT_UNKNOWN_CA"


async def test_a_client_refuses_a_broker_it_cannot_trust(
    pki: TemporaryPki, broker: BrokerAddress
) -> None:
    agv = Identity.from_pki(pki.directory, "agv-01")
    probe_broker(mqtt_link(broker, tls=agv))  # the broker's certificate names 127.0.0.1
    by_name = BrokerAddress("localhost", broker.port)
    with pytest.raises(BrokerError, match=r"its certificate is refused .*issued for localhost"):
        probe_broker(mqtt_link(by_name, tls=agv))
    with TemporaryPki(fleet="elsewhere") as other:
        stranger = other.identity("agv-01", role="agv")
        with pytest.raises(BrokerError, match="its certificate is refused"):
            probe_broker(mqtt_link(broker, tls=stranger))


# -- what each may do ---------------------------------------------------------------------


async def test_a_vehicle_cannot_command_another(
    pki: TemporaryPki, broker: BrokerAddress, master: MqttLink
) -> None:
    async with probe(master) as p, vehicle(link_of(pki, broker, "agv-01"), p) as agv01:
        one = agv01.one
        order = make_order(one.layout, "agv-01", one.path(one.layout.station("pick-A3-1").point))
        async with attacker(link_of(pki, broker, "agv-02")) as agv02:
            pause = instant("agv-01", ("pause", "startPause"))
            await agv02.publish(topic("agv-01", "instantActions"), json.dumps(pause), qos=1)
            await agv02.publish(topic("agv-01", "order"), json.dumps(order), qos=1)
            await agv02.publish(topic("agv-02", "state"), b"{}", qos=1)
            await p.wait_for(
                lambda: bool(p.of("agv-02", "state")), within=WITHIN, why="agv-02's own"
            )
        await answered(p, "agv-01", "after-the-forgeries")
        assert one.endpoint.received == 1, "agv-01 heard only the master"
        assert not one.agv.paused
        assert agv01.state["orderId"] == ""
        assert [s.message["actions"][0]["actionId"] for s in p.of("agv-01", "instantActions")] == [
            "after-the-forgeries"
        ]
        assert p.of("agv-01", "order") == []


async def test_a_vehicle_cannot_read_another_s_commands(
    pki: TemporaryPki, broker: BrokerAddress, master: MqttLink
) -> None:
    heard: list[str] = []
    async with probe(master) as p, attacker(link_of(pki, broker, "agv-02")) as agv02:
        for wanted in (topic("agv-01", "order"), topic("agv-01", "instantActions"), "uagv/#"):
            await agv02.subscribe(wanted, qos=1)
        await agv02.subscribe(topic("agv-02", "instantActions"), qos=1)

        async def listen() -> None:
            async for message in agv02.messages:
                heard.append(str(message.topic))

        listener = asyncio.get_running_loop().create_task(listen())
        try:
            one = OneVehicle()
            await p.send("agv-01", "order", make_order(one.layout, "agv-01", [one.home]))
            await p.send("agv-01", "instantActions", instant("agv-01", ("p", "startPause")))
            await p.send("agv-02", "instantActions", instant("agv-02", ("r", "stateRequest")))
            await until(lambda: topic("agv-02", "instantActions") in heard, within=WITHIN)
        finally:
            listener.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await listener
    assert heard
    assert all("/agv-02/" in t for t in heard), heard


async def test_a_vehicle_cannot_speak_for_another(
    pki: TemporaryPki, broker: BrokerAddress, master: MqttLink
) -> None:
    async with probe(master) as p:
        async with attacker(link_of(pki, broker, "agv-02")) as agv02:
            forged = json.dumps({"connectionState": "ONLINE"})
            await agv02.publish(topic("agv-01", "connection"), forged, qos=1, retain=True)
            for subtopic in ("state", "visualization", "factsheet"):
                await agv02.publish(topic("agv-01", subtopic), b"{}", qos=1, retain=True)
            await agv02.publish(topic("agv-02", "connection"), forged, qos=1, retain=True)
            await p.wait_for(
                lambda: bool(p.of("agv-02", "connection")), within=WITHIN, why="marker"
            )
        assert [s for s in p.seen if s.serial == "agv-01"] == []

    # Nothing was retained for agv-01: a newcomer is given agv-02's message and no other.
    retained: list[str] = []
    async with link_of(pki, broker, MONITOR_ID).client() as newcomer:
        await newcomer.subscribe(topic("agv-01", "connection"), qos=1)
        await newcomer.subscribe("uagv/v3/+/agv-01/#", qos=1)
        await newcomer.subscribe(topic("agv-02", "connection"), qos=1)
        async with asyncio.timeout(WITHIN):
            async for message in newcomer.messages:
                retained.append(str(message.topic))
                if message.topic.matches(topic("agv-02", "connection")):
                    break
    assert retained == [topic("agv-02", "connection")]


async def test_another_certificate_asking_for_a_vehicle_s_client_id_does_not_kick_it(
    pki: TemporaryPki, broker: BrokerAddress, master: MqttLink
) -> None:
    async with probe(master) as p, vehicle(link_of(pki, broker, "agv-01"), p) as agv01:
        stolen_ids = ("agv-01", f"{MANUFACTURER}-agv-01")  # its id, and the plain bridge's
        for stolen in stolen_ids:
            async with attacker(link_of(pki, broker, "agv-02"), identifier=stolen) as agv02:
                # The broker named it after its certificate: it may speak as agv-02 only.
                await agv02.publish(topic("agv-02", "state"), json.dumps({"as": stolen}), qos=1)
                await p.wait_for(
                    said(p, "agv-02", {"as": stolen}),
                    within=WITHIN,
                    why=f"the attacker connected, asking for {stolen}",
                )
            await answered(p, "agv-01", f"still-there-after-{stolen}")
        assert agv01.counters.connected
        assert agv01.counters.connects == 1
        states = [c.message["connectionState"] for c in p.of("agv-01", "connection")]
        assert states == ["ONLINE"]


async def test_a_master_control_commands_every_vehicle(
    pki: TemporaryPki, broker: BrokerAddress, master: MqttLink
) -> None:
    async with (
        probe(master) as p,
        vehicle(link_of(pki, broker, "agv-01"), p) as agv01,
        vehicle(link_of(pki, broker, "agv-02"), p) as agv02,
    ):
        for serial, running in (("agv-01", agv01), ("agv-02", agv02)):
            one = running.one
            path = one.path(one.layout.station("pick-A3-1").point)
            await p.send(serial, "order", make_order(one.layout, serial, path, order_id=serial))
            await p.send(serial, "instantActions", instant(serial, ("hold", "startPause")))
        for serial in ("agv-01", "agv-02"):
            await p.wait_for(
                took_and_paused(p, serial), within=WITHIN, why=f"{serial} took the order, paused"
            )
        assert agv01.one.agv.paused
        assert agv02.one.agv.paused


async def test_a_master_issued_while_the_broker_runs_gets_its_rights(
    pki: TemporaryPki, local_broker: LocalBroker, broker: BrokerAddress, master: MqttLink
) -> None:
    async with probe(master) as p, vehicle(link_of(pki, broker, "agv-01"), p):
        before = local_broker.reloads
        second = pki.identity("master-2", role="master")
        await until(lambda: local_broker.reloads > before, within=WITHIN)
        async with probe(mqtt_link(broker, tls=second)) as p2:
            await answered(p2, "agv-01", "from-master-2")


# -- revocation ---------------------------------------------------------------------------


async def test_a_revoked_vehicle_is_refused_on_its_next_connect(
    pki: TemporaryPki,
    local_broker: LocalBroker,
    broker: BrokerAddress,
    master: MqttLink,
    caplog: pytest.LogCaptureFixture,
) -> None:
    caplog.set_level(logging.WARNING, logger="agv_app.vda5050.bridge")
    agv01 = link_of(pki, broker, "agv-01")  # read while it was valid
    async with probe(master) as p:
        async with vehicle(agv01, p):
            before = local_broker.reloads
            revoke(pki.directory, "agv-01")
            await until(lambda: local_broker.reloads > before, within=WITHIN)
        alert = await connects(agv01.tls_context(), broker, "agv-01")
        assert alert == "SSLV3_ALERT_CERTIFICATE_REVOKED"
        with pytest.raises(BrokerError, match=r"refused the certificate .*agv-01\.pem.*revoked"):
            probe_broker(agv01)
        async with vehicle(agv01) as again:
            await until(lambda: "the certificate is revoked" in caplog.text, within=WITHIN)
            assert again.counters.connects == 0
        others = link_of(pki, broker, "agv-02").tls_context()
        assert await connects(others, broker, "agv-02") == "accepted"
