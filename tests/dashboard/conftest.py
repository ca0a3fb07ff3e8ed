"""Fixtures: the dashboard over a real simulated ObjectPlaces network.

``NetworkSource`` is a ``FleetSource`` made of real middleware nodes (an observer, a
few parked nodes with positions, and station nodes) on the demo warehouse. It drives
no vehicles: that is the fleet's job; it exists so the REST API's sessions, polls and
group views run against the real middleware.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pytest

from agv_app.layout import Layout, demo_warehouse
from dashboard.app import create_app
from dashboard.source import InitiatorFactory, UnknownStationError, VehicleView
from objectplaces import RoleActivator
from objectplaces.sim import SimulatedNetwork
from tests.dashboard.login import TestClient, anonymous, logged_in

__all__ = ["PARKED", "FailingSource", "NetworkSource", "TestClient", "advance"]

PARKED = {"agv-1": (10.0, 9.0), "agv-2": (14.0, 9.0), "agv-3": (40.0, 30.0)}


class NetworkSource:
    """Real nodes on a simulated network, parked; tasks are only counted."""

    def __init__(self) -> None:
        self.layout = demo_warehouse()
        self.net = SimulatedNetwork(seed=1, delay=0.005)
        self._nodes: dict[str, RoleActivator] = {"dashboard": self.net.add_node("dashboard")}
        for node_id, (x, y) in PARKED.items():
            node = self.net.add_node(node_id)
            node.update_node_property("position", (x, y))
            node.update_node_property("hull_length", 1.5)
            node.update_node_property("status", "idle")
            self._nodes[node_id] = node
        self.tasks: list[str] = []
        self._paused = False
        self._speed = 1.0
        self.net.run_for(0.5)

    def layout_view(self) -> Layout:
        return self.layout

    def vehicles(self) -> Sequence[VehicleView]:
        return []

    def nodes(self) -> Mapping[str, RoleActivator]:
        return self._nodes

    @property
    def observer_id(self) -> str:
        return "dashboard"

    def initiator_roles(self) -> Mapping[str, InitiatorFactory]:
        return {}

    def metrics(self) -> Mapping[str, float]:
        stats = [n.stats() for n in self._nodes.values()]
        return {
            "tasks_created": float(len(self.tasks)),
            "messages": float(sum(s.messages_sent for s in stats)),
        }

    def create_task(self, station_id: str) -> str:
        station = self.layout.stations.get(station_id)
        if station is None:
            raise UnknownStationError(station_id)
        if station.kind in ("parking", "charging"):
            raise ValueError(f"station {station_id!r} is a {station.kind} spot, not a workstation")
        self.tasks.append(station_id)
        return f"task-{len(self.tasks)}"

    def pause(self) -> None:
        self._paused = True

    def resume(self) -> None:
        self._paused = False

    def set_speed(self, factor: float) -> None:
        if not factor > 0:
            raise ValueError(f"speed must be > 0, got {factor!r}")
        self._speed = factor

    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def speed(self) -> float:
        return self._speed

    @property
    def now(self) -> float:
        return self.net.now

    def advance(self, seconds: float) -> None:
        self.net.run_for(seconds)


class FailingSource(NetworkSource):
    """A ``NetworkSource`` whose ``advance`` raises on the calls numbered in ``failing``
    (1 is the first call); the others advance the network as usual."""

    def __init__(self, failing: set[int]) -> None:
        super().__init__()
        self.failing = failing
        self.calls = 0
        self.advanced: list[float] = []

    def advance(self, seconds: float) -> None:
        self.calls += 1
        if self.calls in self.failing:
            raise ZeroDivisionError(f"step {self.calls} fails")
        self.advanced.append(seconds)
        super().advance(seconds)


@pytest.fixture
def source() -> NetworkSource:
    return NetworkSource()


@pytest.fixture
def client(source: NetworkSource) -> TestClient:
    """The app without its real-time runner, and an operator: tests advance the network
    themselves."""
    return logged_in(create_app(source))


@pytest.fixture
def stranger(source: NetworkSource) -> TestClient:
    """The app, and a client without a token."""
    return anonymous(create_app(source))


def advance(source: NetworkSource, seconds: float = 0.5) -> None:
    """Let the network deliver what the last request caused."""
    source.advance(seconds)
