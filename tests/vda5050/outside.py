"""A master control nobody here wrote: ``vda5050-sdk`` (the package index's VDA 5050 client
for Python), driving our vehicles over the test's broker.

Its ``MasterClient`` builds, checks and publishes the orders (its ``OrderBuilder``: the
sequence ids, base and horizon) and instant actions, and follows each vehicle's state
to decide whether a new order may go (its ``OrderAcceptancePolicy``). Two things are
ours, as an integrator would add them:

- :class:`CheckedTransport`, the client's transport port (``vda5050.ports.transport.
  ITransport``) on our link: mutual TLS with the master's certificate, which the
  client's own MQTT adapter cannot present. It checks every message both ways against
  the VDA 5050 3.0 schemas and counts the failures.
- :func:`as_2_1`: the client models VDA 5050 2.1 messages (``batteryState``,
  ``agvPosition``, ``eStop``, ``CONNECTIONBROKEN``, two error levels); a 3.0 state is
  handed to it with those fields added beside the 3.0 ones, or its session logic would
  never see a state. Every check of ours reads the 3.0 message as it came.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import itertools
import json
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

import aiomqtt
from vda5050 import Action, ActionParameter, BlockingType, MasterClient, MasterConfig, OrderBuilder
from vda5050.topics import topic_matches

from agv_app.layout.graph import Layout
from agv_app.vda5050.link import MqttLink
from agv_app.vda5050.mapping import vda_edge_id
from agv_app.vda5050.topics import MANUFACTURER, PROTOCOL_VERSION
from agv_app.vda5050.validation import schema_errors
from tests.waiting import until

Handler = Callable[[str, bytes], Awaitable[None]]
_LEVELS_2_1 = {"WARNING": "WARNING", "URGENT": "WARNING", "CRITICAL": "FATAL", "FATAL": "FATAL"}


def as_2_1(subtopic: str, message: dict[str, Any]) -> dict[str, Any]:
    """A 3.0 message with the 2.1 fields the client needs added (see the module doc)."""
    out = dict(message)
    if subtopic == "connection" and message.get("connectionState") == "CONNECTION_BROKEN":
        out["connectionState"] = "CONNECTIONBROKEN"
    if subtopic != "state":
        return out
    power = message.get("powerSupply", {})
    out["batteryState"] = {
        "batteryCharge": power.get("stateOfCharge", 0.0),
        "charging": power.get("charging", False),
    }
    position = message.get("mobileRobotPosition")
    if position is not None:
        out["agvPosition"] = {
            "positionInitialized": position["localized"],
            "x": position["x"],
            "y": position["y"],
            "theta": position["theta"],
            "mapId": position["mapId"],
        }
    safety = message.get("safetyState", {})
    out["safetyState"] = {**safety, "eStop": safety.get("activeEmergencyStop", "NONE")}
    out["errors"] = [
        {**e, "errorLevel": _LEVELS_2_1.get(e.get("errorLevel", ""), "WARNING")}
        for e in message.get("errors", [])
    ]
    out["actionStates"] = [
        *message.get("actionStates", []),
        *message.get("instantActionStates", []),
    ]
    return out


@dataclass
class Traffic:
    """What went through the transport, and what failed its schema."""

    sent: list[tuple[str, dict[str, Any]]] = field(default_factory=list)
    received: dict[tuple[str, str], list[dict[str, Any]]] = field(default_factory=dict)
    schema_failures: list[str] = field(default_factory=list)

    def of(self, serial: str, subtopic: str) -> list[dict[str, Any]]:
        """The 3.0 messages ``serial`` sent on ``subtopic``, oldest first."""
        return self.received.get((serial, subtopic), [])

    def last_state(self, serial: str) -> dict[str, Any]:
        """The last state of ``serial`` (empty: none yet)."""
        states = self.of(serial, "state")
        return states[-1] if states else {}


def _parts(topic: str) -> tuple[str, str]:
    parts = topic.split("/")
    return parts[3], parts[4]


class CheckedTransport:
    """The client's transport port on our link, checking every message both ways."""

    def __init__(self, link: MqttLink) -> None:
        self.link = link
        self.traffic = Traffic()
        self._client: aiomqtt.Client | None = None
        self._handlers: list[tuple[str, Handler]] = []
        self._reader: asyncio.Task[None] | None = None

    def _check(self, topic: str, subtopic: str, message: Any) -> None:
        for problem in schema_errors(subtopic, message):
            self.traffic.schema_failures.append(f"{topic}: {problem}")

    async def connect(self, *, will: Any = None) -> None:
        """Connect with the master's certificate (the client asks no last will)."""
        assert will is None
        client = self.link.client()
        await client.__aenter__()
        self._client = client
        self._reader = asyncio.get_running_loop().create_task(self._read())

    async def disconnect(self) -> None:
        """Stop reading and disconnect."""
        if self._reader is not None:
            self._reader.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reader
        if self._client is not None:
            await self._client.__aexit__(None, None, None)
            self._client = None

    async def publish(
        self, topic: str, payload: bytes, *, qos: int = 0, retain: bool = False
    ) -> None:
        """Check an order or instant actions against its 3.0 schema, then publish it."""
        assert self._client is not None
        _, subtopic = _parts(topic)
        message = json.loads(payload)
        self._check(topic, subtopic, message)
        self.traffic.sent.append((subtopic, message))
        await self._client.publish(topic, payload, qos=qos, retain=retain)

    async def subscribe(self, topic: str, handler: Handler, *, qos: int = 0) -> None:
        """Subscribe ``handler`` to ``topic`` (a filter)."""
        assert self._client is not None
        self._handlers.append((topic, handler))
        await self._client.subscribe(topic, qos=qos)

    async def _read(self) -> None:
        assert self._client is not None
        async for m in self._client.messages:
            topic = str(m.topic)
            payload = m.payload if isinstance(m.payload, bytes) else b""
            serial, subtopic = _parts(topic)
            message = json.loads(payload)
            self._check(topic, subtopic, message)
            self.traffic.received.setdefault((serial, subtopic), []).append(message)
            seen = json.dumps(as_2_1(subtopic, message)).encode()
            for pattern, handler in list(self._handlers):
                if topic_matches(pattern, topic):
                    await handler(topic, seen)


def master_client(transport: CheckedTransport) -> MasterClient:
    """The client as a 3.0 master control on ``transport``, with visualization."""
    config = MasterConfig(protocol_version=PROTOCOL_VERSION, visualization=True)
    return MasterClient(config, transport=transport)


def target(serial: str) -> str:
    """The client's name for a vehicle."""
    return f"{MANUFACTURER}/{serial}"


def transport_order(
    layout: Layout,
    serial: str,
    order_id: str,
    *,
    start: str,
    pick: str,
    drop: str,
    end: str,
    load_id: str,
) -> list[Any]:
    """A transport order built with the client, as an order and two updates to send at
    once: from ``start`` to station ``pick`` (pick ``load_id``), then on to station
    ``drop`` (drop it), then on to ``end``; every node placed on the layout's map.

    One message per leg: the client refuses a message that names an edge twice (3.0
    allows it, with other sequence ids), and a way there and back drives some twice.
    Each update starts at the last node of the one before (the client's
    ``OrderBuilder.from_order`` stitches it on).
    """
    a, b = layout.station(pick).point, layout.station(drop).point
    legs = [
        layout.shortest_path(start, a),
        layout.shortest_path(a, b),
        layout.shortest_path(b, end),
    ]
    actions = [
        _load_action(f"{order_id}-pick", "pick", pick, load_id),
        _load_action(f"{order_id}-drop", "drop", drop, load_id),
        None,
    ]
    messages: list[Any] = []
    for leg, last_action in zip(legs, actions, strict=True):
        if messages:
            builder = OrderBuilder.from_order(messages[-1])
            points = list(leg[1:])
        else:
            builder = OrderBuilder(
                order_id=order_id,
                manufacturer=MANUFACTURER,
                serial_number=serial,
                version=PROTOCOL_VERSION,
            )
            points = list(leg)
        for k, point in enumerate(points):
            p = layout.point(point)
            here = [last_action] if k == len(points) - 1 and last_action is not None else []
            builder.add_node(point, x=p.x, y=p.y, map_id=layout.name, actions=here)
        for u, v in itertools.pairwise(leg):
            edge = vda_edge_id(layout, u, v)
            assert edge is not None
            builder.add_edge(u, v, edge_id=edge)
        messages.append(builder.build())
    return messages


def _load_action(action_id: str, kind: str, station: str, load_id: str) -> Action:
    return Action(
        action_id=action_id,
        action_type=kind,
        blocking_type=BlockingType.HARD,
        action_parameters=[
            ActionParameter(key="loadId", value=load_id),
            ActionParameter(key="stationName", value=station),
        ],
    )


async def dispatch_in_turn(
    client: MasterClient,
    traffic: Traffic,
    serial: str,
    messages: list[Any],
    *,
    within: float = 60.0,
) -> None:
    """Send an order and its updates, each once the vehicle's state shows the one before
    (the client's acceptance policy checks an update against the last state it saw)."""
    for message in messages:
        result = await client.dispatch(message, target=target(serial))
        assert result.accepted, result
        shown = (message.order_id, message.order_update_id)

        def taken(shown: tuple[str, int] = shown) -> bool:
            state = traffic.last_state(serial)
            return (state.get("orderId"), state.get("orderUpdateId")) == shown

        await until(taken, within=within)


def finished(traffic: Traffic, serial: str, order_id: str) -> bool:
    """True once ``serial``'s last state shows ``order_id`` done: every node reached,
    every action ended, standing."""
    state = traffic.last_state(serial)
    return (
        state.get("orderId") == order_id
        and state["nodeStates"] == []
        and not state["driving"]
        and all(a["actionStatus"] in ("FINISHED", "FAILED") for a in state["actionStates"])
    )


@dataclass(frozen=True)
class Figures:
    """What a run of transport orders came to."""

    orders: int
    finished: int
    errors: int
    schema_failures: int
    wall_s: float
    sim_s: float


def station_pairs(vehicle: int, orders: int) -> list[tuple[str, str]]:
    """Pick and drop stations for the ``vehicle``-th vehicle (0..3): two aisles of its own,
    a pick in one and a drop in the other, alternating (the master keeps vehicles out of
    each other's stations, as it plans where they go)."""
    aisles = (2 * vehicle + 1, 2 * vehicle + 2)
    return [(f"pick-A{aisles[k % 2]}-1", f"drop-A{aisles[(k + 1) % 2]}-3") for k in range(orders)]


async def carry(
    client: MasterClient,
    traffic: Traffic,
    layout: Layout,
    serial: str,
    pairs: list[tuple[str, str]],
    *,
    within: float,
) -> int:
    """Give ``serial`` one transport order per pair, each once the last has finished,
    from its resting place and back there; how many finished."""
    done = 0
    home = traffic.last_state(serial)["lastNodeId"]
    for k, (pick, drop) in enumerate(pairs):
        order_id = f"{serial}-transport-{k + 1}"
        messages = transport_order(
            layout,
            serial,
            order_id,
            start=home,
            pick=pick,
            drop=drop,
            end=home,
            load_id=f"load-{serial}-{k + 1}",
        )
        await dispatch_in_turn(client, traffic, serial, messages, within=within)
        await until(functools.partial(finished, traffic, serial, order_id), within=within)
        done += 1
    return done


def errors_seen(traffic: Traffic) -> int:
    """Distinct errors any vehicle reported in any state."""
    seen = {
        (serial, e["errorType"], e.get("errorDescription", ""))
        for (serial, subtopic), states in traffic.received.items()
        if subtopic == "state"
        for s in states
        for e in s["errors"]
    }
    return len(seen)
