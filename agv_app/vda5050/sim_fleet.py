"""The simulated fleet speaking VDA 5050: one MQTT client per AGV, in this process.

:class:`VdaSimFleet` is the :class:`~agv_app.fleet.sim.Fleet` with order-following AGVs
(:class:`~agv_app.vda5050.vehicle.OrderAgv`) and, once started, one bridge per AGV and
a broker monitor on the event loop that advances it. Its AGVs move in simulated time
(the dashboard's speed factor applies); their messages carry wall-clock timestamps. No
task arrives by itself: the master control sends orders. A transport order (one with a
pick or a drop) shows in the fleet's task book as a task of creator ``master``, from the
station of its first pick to the station of its last drop, on its vehicle, until it
has finished (``done``) or was cancelled (:class:`MasterOrders`).

Every AGV's client connects with that AGV's own certificate (role ``agv``, its id the
serial number), the monitor with its own (role ``control``), all from one
:class:`~agv_app.vda5050.link.VdaCredentials`: a PKI folder, a throwaway PKI that
issues them, or plain links on loopback.

``await fleet.start()`` before use and ``await fleet.stop()`` after (the dashboard's
app does both in its lifespan); ``stop`` says ``OFFLINE`` for every AGV.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import functools
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from agv_app.fleet.sim import Fleet, FleetConfig
from agv_app.fleet.view import VehicleState
from agv_app.layout.graph import Layout
from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.book import TaskBook
from agv_app.vda5050.bridge import BridgeCounters, run_bridge
from agv_app.vda5050.endpoint import VdaEndpoint
from agv_app.vda5050.handling import station_for
from agv_app.vda5050.link import MqttLink, VdaCredentials
from agv_app.vda5050.monitor import MONITOR_ID, MONITOR_ROLES, BrokerMonitor
from agv_app.vda5050.order import OrderBook
from agv_app.vda5050.process import VEHICLE_ROLES
from agv_app.vda5050.topics import MANUFACTURER, VehicleTopics, parse_broker_url
from agv_app.vda5050.vehicle import OrderAgv
from objectplaces.core.errors import LocalProtocolError

__all__ = ["MasterOrders", "VdaSimFleet"]


class MasterOrders:
    """Enters the transport orders of a master control into a task book (each vehicle's
    ``on_order``).

    Args:
        book: the fleet's task book.
        layout: the floor plan, for the stations at the order's nodes.
        clock: the fleet's simulated seconds.
    """

    def __init__(self, book: TaskBook, layout: Layout, clock: Callable[[], float]) -> None:
        self.book = book
        self.layout = layout
        self.clock = clock
        self._open: dict[tuple[str, str], str] = {}
        """Each open order's task id, by vehicle and orderId."""

    def carried_by(self, serial: str) -> str | None:
        """The task id of the transport order ``serial`` carries out (None: none)."""
        return next((t for (s, _), t in self._open.items() if s == serial), None)

    def seen(self, serial: str, event: str, orders: OrderBook) -> None:
        """An order of ``serial`` was accepted, finished or cancelled."""
        key = (serial, orders.order_id)
        now = self.clock()
        if event == "accepted":
            task = self._task(serial, orders)
            if task is not None:
                self.book.add_held(task, serial, now=now, creator="master")
                self._open[key] = task.id
            return
        task_id = self._open.pop(key, None)
        if task_id is None:
            return
        if event == "finished":
            self.book.finish(task_id, now=now)
        else:
            self.book.withdraw(task_id, now=now)

    def _task(self, serial: str, orders: OrderBook) -> TaskSpec | None:
        """The order as a task (None: it neither picks nor drops)."""
        records = orders.actions.records.values()
        picks = [r.action.node_id for r in records if r.action.action_type == "pick"]
        drops = [r.action.node_id for r in records if r.action.action_type == "drop"]
        if not picks and not drops:
            return None
        source = picks[0] if picks else orders.last_node_id
        target = drops[-1] if drops else source
        task_id = orders.order_id
        if self.book.get(task_id) is not None:
            task_id = f"{orders.order_id}@{serial}"
        return TaskSpec(task_id, self._station(source, "pick"), self._station(target, "drop"))

    def _station(self, point: str, kind: str) -> str:
        kinds = frozenset({kind, "pickdrop"})
        return station_for(self.layout, point, kinds) or point


class VdaSimFleet(Fleet):
    """A simulated fleet whose every AGV has its own VDA 5050 client.

    Args:
        layout: the floor plan (default: the demo warehouse).
        agvs: number of AGVs.
        seed: seeds the network.
        vda5050: the broker, ``mqtts://HOST:PORT`` (``mqtt://`` on loopback, insecure).
        credentials: where the clients' certificates come from.
        monitor_id: the broker monitor's id in the PKI (role ``control``).
        fleet_options: further :class:`~agv_app.fleet.sim.FleetConfig` fields.

    Raises:
        ValueError: a malformed broker address.
        LocalProtocolError: the address and the credentials do not go together
            (:func:`~agv_app.vda5050.link.mqtt_link`).
        CredentialError: an AGV's or the monitor's certificate is missing or unusable.
    """

    def __init__(
        self,
        layout: Layout | None = None,
        *,
        agvs: int = 12,
        seed: int = 1,
        vda5050: str,
        credentials: VdaCredentials,
        monitor_id: str = MONITOR_ID,
        **fleet_options: Any,
    ) -> None:
        broker = parse_broker_url(vda5050)
        if not isinstance(credentials, VdaCredentials):
            raise LocalProtocolError(
                f"the VDA 5050 clients need credentials=VdaCredentials(...), got {credentials!r}"
            )
        config = FleetConfig(agvs=agvs, seed=seed, task_until=0.0, **fleet_options)
        super().__init__(
            layout, config, vehicle=functools.partial(OrderAgv, manufacturer=MANUFACTURER)
        )
        self.master_orders = MasterOrders(self.desk.book, self.layout, lambda: self.net.now)
        for agv_id, agv in self.agvs.items():
            if isinstance(agv, OrderAgv):
                agv.on_order = functools.partial(self.master_orders.seen, agv_id)
        self.vda5050 = broker.url
        self.broker = broker
        self.endpoints = {
            agv_id: VdaEndpoint(agv, VehicleTopics(MANUFACTURER, agv_id))
            for agv_id, agv in self.agvs.items()
            if isinstance(agv, OrderAgv)
        }
        self.links: dict[str, MqttLink] = {
            agv_id: credentials.link(broker, agv_id, roles=VEHICLE_ROLES)
            for agv_id in self.endpoints
        }
        self.counters = {agv_id: BridgeCounters() for agv_id in self.endpoints}
        self.broker_monitor = BrokerMonitor(
            credentials.link(broker, monitor_id, roles=MONITOR_ROLES)
        )
        self._tasks: list[asyncio.Task[None]] = []

    @property
    def started(self) -> bool:
        """Whether the bridges run."""
        return bool(self._tasks)

    async def start(self) -> None:
        """Start every AGV's bridge and the broker monitor (they connect in the background).

        Raises:
            RuntimeError: called twice.
        """
        if self._tasks:
            raise RuntimeError("VdaSimFleet.start() called twice")
        loop = asyncio.get_running_loop()
        for agv_id, endpoint in self.endpoints.items():
            bridge = run_bridge(endpoint, self.links[agv_id], counters=self.counters[agv_id])
            self._tasks.append(loop.create_task(bridge, name=f"vda5050-{agv_id}"))
        self._tasks.append(loop.create_task(self.broker_monitor.run(), name="vda5050-monitor"))

    async def stop(self) -> None:
        """Stop the bridges (each says ``OFFLINE``) and the monitor. Idempotent."""
        tasks, self._tasks = self._tasks, []
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task

    def vehicles(self) -> Sequence[VehicleState]:
        """Every AGV, by id; one carrying out a master's transport order shows it as its
        task."""
        return [
            v
            if v.task_id is not None or (order := self.master_orders.carried_by(v.id)) is None
            else dataclasses.replace(v, task_id=order)
            for v in super().vehicles()
        ]

    def metrics(self) -> Mapping[str, float]:
        """The fleet's figures and the broker's (``vda5050_*``)."""
        return {**super().metrics(), **self.broker_monitor.status()}
