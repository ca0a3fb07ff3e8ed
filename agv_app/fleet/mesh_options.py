"""Choices of a mesh fleet (:class:`~agv_app.fleet.mesh.MeshFleet`) made before it
starts: how its AGV processes run and link (:class:`AgvLaunch`), how often they report
their poses, and how a control process joins a fleet whose vehicles run elsewhere
(:class:`Joining`).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agv_app.fleet.agv_args import process_liveness
from agv_app.fleet.liveness import liveness_arguments
from agv_app.vehicle.battery import BatterySpec

__all__ = ["HOST", "POSES_PER_SECOND", "AgvLaunch", "Joining", "pose_interval_for"]

HOST = "127.0.0.1"
"""Where a mesh fleet's own nodes, router and AGV processes listen."""

POSES_PER_SECOND = 100.0
"""About how many poses a whole fleet of AGV processes reports a second when moving."""


def pose_interval_for(agvs: int) -> float:
    """Seconds between two pose reports of an AGV in a fleet of ``agvs``: 0.2 s up to 20
    AGVs, then longer, so that the fleet's poses stay about ``POSES_PER_SECOND``.

    Every pose goes to the observer, in the dashboard's process, over the display
    session (:mod:`agv_app.fleet.display_feed`): the observer alone draws from them.
    Safety does not wait for them (an AGV publishes its position and hull length with
    every request and release).
    """
    return max(0.2, agvs / POSES_PER_SECOND)


@dataclass(frozen=True)
class Joining:
    """How a control process joins a fleet whose vehicles run elsewhere
    (``objectplaces control``): it spawns nothing, and learns the AGVs as it hears them.

    Attributes:
        connect: where the fleet is: nodes to join (the mesh) or routers (Zenoh).
        listen: where the observer listens (the mesh: AGVs may join through it).
        pki: the fleet PKI folder with the certificates of ``observer`` and ``base``.
        layout_argument: the ``--layout`` the fleet runs (for the record and messages).
    """

    connect: tuple[str, ...]
    listen: str = f"{HOST}:0"
    pki: Path | None = None
    layout_argument: str | None = None


@dataclass(frozen=True, slots=True)
class AgvLaunch:
    """How a mesh fleet's AGV processes run and link: the options of
    :class:`~agv_app.fleet.mesh.MeshFleet` of these names.

    Attributes:
        tag: the layout's tag (``layout:<digest>``): nodes of other layouts refuse them.
        seed: seeds the processes (each its own, from this and its index).
        t_update: property update interval of every node (the safe time is twice it).
        run_seconds: every AGV process stops by itself after this long.
        dwell: seconds an AGV spends at a station.
        transport: ``websocket`` (the mesh) or ``zenoh``.
        zenoh_mode: on Zenoh, ``client`` (a router in the fleet's process, every node
            its client) or ``peer`` (every node a peer, found through the observer).
        publish_interval: seconds between two pose reports of a moving AGV to the
            observer; the sessions, roles and traffic each AGV shows the dashboard go
            out at most five times as seldom.
        republish_beats: liveness beats between two republications of every property,
            by every node (0: no beats, everything republished each ``t_update``).
        rest_beat: an AGV parked at its home with no task, the transport base and the
            observer beat only this often, and every node waits that much longer for
            them (None: no rest; with beats only; docs/protocol.md §2, "A node at rest").
        poll_interval: on Zenoh, the AGV processes hand received frames on every this
            many seconds (0: each at once; ``agv_app.fleet.agv_process``).
        vda5050: ``mqtts://HOST:PORT`` of a broker every AGV process speaks VDA 5050 over.
        batteries: every AGV process has a battery (True: ``BatterySpec()``; a
            ``BatterySpec``: that one), reports its state of charge (``battery``, VDA 5050
            ``powerSupply``) and charges as the control grants
            (:mod:`agv_app.fleet.mesh_charging`).

    Raises:
        ValueError: an unknown ``zenoh_mode``, or a ``rest_beat`` that is not a positive
            number.
    """

    tag: str
    seed: int
    t_update: float
    run_seconds: float
    dwell: float
    transport: str
    zenoh_mode: str
    publish_interval: float
    republish_beats: int
    rest_beat: float | None
    poll_interval: float
    vda5050: str | None
    batteries: bool | BatterySpec = False

    def __post_init__(self) -> None:
        if self.zenoh_mode not in ("client", "peer"):
            raise ValueError(f"zenoh_mode must be 'client' or 'peer', got {self.zenoh_mode!r}")
        rest = self.rest_beat
        if rest is not None and not (rest > 0 and math.isfinite(rest)):
            raise ValueError(f"rest_beat must be a positive number, got {rest!r}")

    @property
    def battery_spec(self) -> BatterySpec | None:
        """The AGV processes' battery (None: none)."""
        if isinstance(self.batteries, BatterySpec):
            return self.batteries
        return BatterySpec() if self.batteries else None

    def node_arguments(self) -> dict[str, Any]:
        """The options of the nodes in the fleet's process: liveness, tag, polling."""
        liveness = process_liveness(self.t_update, self.republish_beats, self.rest_beat)
        node_args: dict[str, Any] = {**liveness_arguments(liveness), "tag": self.tag}
        if self.transport == "zenoh":
            node_args["poll_interval"] = self.poll_interval or None
        return node_args

    def arguments(
        self, index: int, home: str, link_args: list[str], pki: Path, peers: int
    ) -> list[str]:
        """The command line of the ``index``-th AGV process, parked at ``home``."""
        return [
            "--listen", f"{HOST}:0",
            *link_args,
            "--pki", str(pki),
            "--home", home,
            "--seed", str(self.seed * 1000 + index),
            "--run-seconds", str(self.run_seconds),
            "--t-update", str(self.t_update),
            "--publish-interval", str(self.publish_interval),
            "--introspection-interval", str(5 * self.publish_interval),
            "--dwell", str(self.dwell),
            *_battery_arguments(self.battery_spec),
            "--expect-peers", str(peers),
            *([] if self.vda5050 is None else ["--vda5050", self.vda5050]),
        ]  # fmt: skip


def _battery_arguments(spec: BatterySpec | None) -> list[str]:
    if spec is None:
        return []
    return ["--battery", "--battery-spec", json.dumps(dataclasses.asdict(spec))]
