"""The nodes a mesh fleet runs in its own process: the observer (no position, hears
every node) and the transport base, with the fleet PKI they and the AGV processes take
their certificates from and, on Zenoh in client mode, the router every node is a client
of; started for a fleet of spawned AGV processes, or joined to a fleet that runs
elsewhere (:class:`~agv_app.fleet.mesh_options.Joining`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from agv_app.fleet.display_feed import DISPLAY_ROLE, display_group
from agv_app.fleet.mesh_options import HOST, AgvLaunch, Joining
from agv_app.fleet.mesh_orders import ANSWERS, OperatorOrders
from agv_app.fleet.mesh_watch import ObservedAgvs
from agv_app.fleet.view import OBSERVER_ID
from agv_app.protocol import OBSERVER_KIND
from agv_app.tasks.desk import BASE_ID
from agv_app.vda5050.link import VdaCredentials
from agv_app.vda5050.monitor import MONITOR_ID, MONITOR_ROLES, BrokerMonitor
from objectplaces.mesh import MeshNode, start_node
from objectplaces.security import Identity, TemporaryPki
from objectplaces.zenoh_router import ZenohRouter, start_router

__all__ = ["LocalNodes", "vda5050_monitor"]


def vda5050_monitor(
    vda5050: str | None, credentials: VdaCredentials | None
) -> tuple[TemporaryPki | None, BrokerMonitor | None]:
    """With a broker (``vda5050``), the broker's throwaway PKI, which the run issues
    every certificate from, and a monitor of the broker; else neither.

    Raises:
        ValueError: a broker without ``credentials`` holding a throwaway PKI.
    """
    if vda5050 is None:
        return None, None
    if credentials is None or not isinstance(credentials.pki, TemporaryPki):
        raise ValueError(
            "vda5050 needs vda5050_credentials with the broker's throwaway PKI "
            "(the AGV processes hold one certificate for the mesh and the broker)"
        )
    return credentials.pki, BrokerMonitor(
        credentials.link(vda5050, MONITOR_ID, roles=MONITOR_ROLES)
    )


class LocalNodes:
    """A mesh fleet's observer and transport base, its PKI and its router.

    Args:
        shared_pki: a PKI the run shares (the VDA 5050 broker's), kept on ``remove_pki``
            (None: each start makes a throwaway one).
        seen: what the observer hears goes there: its display session, every AGV's
            ``last_done`` and every node that departs.
        orders: the operator's orders, the observer's properties every AGV process
            follows, and what the processes answer them (:mod:`agv_app.fleet.mesh_orders`).
    """

    def __init__(
        self,
        shared_pki: TemporaryPki | None,
        seen: ObservedAgvs,
        orders: OperatorOrders,
    ) -> None:
        self.shared_pki = shared_pki
        self.seen = seen
        self.orders = orders
        self.observer: MeshNode | None = None
        self.base: MeshNode | None = None
        self.router: ZenohRouter | None = None
        self.pki: TemporaryPki | None = None

    def publish(self, name: str, value: object) -> None:
        """Publish one of the operator's orders as the observer's property (nothing
        while the observer is not running)."""
        if self.observer is not None and not self.observer.closed:
            self.observer.update_node_property(name, value)

    async def start_observer(self, tls: Identity, node_args: Mapping[str, Any]) -> MeshNode:
        """Start the observer: it says what it is, rests, publishes the operator's orders
        and plays the display session's initiator."""
        observer: MeshNode = await start_node(OBSERVER_ID, tls=tls, **node_args)
        observer.update_node_property("kind", OBSERVER_KIND)
        observer.set_at_rest(True)  # it listens, and says nothing more
        self.observer = observer
        for name, value in self.orders.wire().items():
            self.publish(name, value)
        observer.register_node_property_observer(self.orders.answer, names=ANSWERS)
        seen = self.seen
        observer.register_node_property_observer(seen.on_property, names=("last_done",))
        observer.start_interaction(seen.display, display_group(), DISPLAY_ROLE)
        observer.register_node_departure_observer(lambda node_id, _: seen.departed(node_id))
        return observer

    async def join(self, joining: Joining, node_args: dict[str, Any], zenoh: bool) -> MeshNode:
        """Start the observer and the base as members of a fleet that runs elsewhere.

        Returns:
            The base.

        Raises:
            ValueError: ``joining`` names no PKI folder.
        """
        if joining.pki is None:
            raise ValueError("joining a fleet needs the fleet PKI folder (pki=...)")
        observer_id = Identity.from_pki(joining.pki, OBSERVER_ID)
        base_id = Identity.from_pki(joining.pki, BASE_ID)
        if zenoh:
            node_args.update(transport="zenoh", mode="client", connect=list(joining.connect))
            base_link: dict[str, Any] = {}
        else:
            base_link = {"join": [*joining.connect]}
        observer = await self.start_observer(
            observer_id,
            {
                **node_args,
                **({} if zenoh else {"listen": joining.listen, "join": [*joining.connect]}),
            },
        )
        if not zenoh:
            base_link["join"].append(observer.address)
        self.base = await start_node(BASE_ID, tls=base_id, **base_link, **node_args)
        return self.base

    async def start(
        self,
        agv_ids: list[str],
        node_args: dict[str, Any],
        launch: AgvLaunch,
    ) -> list[str]:
        """Make the PKI (a certificate for each of ``agv_ids``), start the router (Zenoh,
        client mode), the observer and the base.

        Returns:
            The arguments that link an AGV process to them (and set its liveness).
        """
        zenoh, zenoh_mode = launch.transport == "zenoh", launch.zenoh_mode
        self.pki = pki = self.shared_pki or TemporaryPki(fleet="demo")
        for agv_id in agv_ids:
            pki.identity(agv_id, role="agv")
        link: dict[str, Any]
        if zenoh and zenoh_mode == "client":
            # One router and every node its client: a link per node, where peers would
            # open one per pair (1,225 at 50 AGVs): Zenoh peers do not relay for each other.
            self.router = await start_router(
                tls=pki.identity("router", role="router", addresses=(HOST,)),
                listen=[f"tls/{HOST}:0"],
            )
            endpoints = self.router.endpoints
            node_args.update(transport="zenoh", mode="client", connect=endpoints)
            link = {}
            link_args = ["--transport", "zenoh", "--mode", "client"]
            link_args += [a for e in endpoints for a in ("--connect", e)]
        elif zenoh:  # every node a peer; the others find each other through the observer
            node_args.update(transport="zenoh", listen=[f"tls/{HOST}:0"])
        else:
            node_args["listen"] = f"{HOST}:0"
        observer = await self.start_observer(pki.identity(OBSERVER_ID, role="control"), node_args)
        if not (zenoh and zenoh_mode == "client"):
            link = {"connect": [observer.address]} if zenoh else {"join": [observer.address]}
            link_args = ["--transport", "zenoh", "--connect"] if zenoh else ["--join"]
            link_args.append(observer.address)
        if zenoh:
            link_args += ["--poll-interval", str(launch.poll_interval)]
        link_args += ["--republish-beats", str(launch.republish_beats)]
        rest_beat = launch.rest_beat
        link_args += ["--rest-beat", "none" if rest_beat is None else str(rest_beat)]
        self.base = await start_node(
            BASE_ID, tls=pki.identity(BASE_ID, role="control"), **link, **node_args
        )
        return link_args

    def live(self) -> list[MeshNode]:
        """The observer and the base, those started and not closed."""
        return [n for n in (self.observer, self.base) if n is not None and not n.closed]

    async def close(self) -> None:
        """Close the base, the observer and the router (those started)."""
        for node in (self.base, self.observer):
            if node is not None:
                await node.close()
        if self.router is not None:
            await self.router.close()
            self.router = None

    def remove_pki(self) -> None:
        """Remove the throwaway PKI (not a shared one)."""
        if self.pki is not None and self.pki is not self.shared_pki:
            self.pki.remove()
        self.pki = None
