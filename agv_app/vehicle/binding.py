"""An AGV on its node: the roles it plays, its first lock, what it keeps of its peers.

The :class:`~agv_app.vehicle.controller.AgvController` owns one :class:`NodeBinding` and
binds to a node through it at start and after a restart (``attach``): the voter
(:mod:`agv_app.traffic.collision`) and bidder (:mod:`agv_app.tasks.auction`) roles, the
check of peers' properties (:mod:`agv_app.traffic.plausibility`), and stale-node
records of failed AGVs.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from agv_app.protocol import AGV_KIND
from agv_app.tasks.auction import Bidder
from agv_app.traffic.collision import Voter
from agv_app.traffic.lockbook import LockEntry, StaleRecord
from agv_app.traffic.plausibility import PeerWatch
from objectplaces import RoleActivator

if TYPE_CHECKING:
    from agv_app.vehicle.controller import AgvController

__all__ = ["NodeBinding"]


class NodeBinding:
    """Binds one AGV to its node (its controller's state, this job's logic).

    Args:
        agv: the controller to bind.
    """

    def __init__(self, agv: AgvController) -> None:
        self._agv = agv
        self._max_peer_hull: float | None = None
        self.at_rest = False
        """True while the AGV is parked at its home with no task (its node beats less
        often then)."""

    def attach(self, node: RoleActivator) -> None:
        """Bind to ``node`` (at start, or after a restart): roles, observers, first lock.

        The AGV stands where it is and locks its own hull without asking: nobody else
        may lock into it (it is inside its last published circle, or, after a failure,
        inside the stale record the others keep of it).
        """
        agv = self._agv
        agv.node = node
        agv.failed = False
        agv._requester = None
        self.at_rest = False  # a new node beats as usual until the AGV parks
        book = agv.book
        book.clear()
        agv._key += 1
        book.set_locks(LockEntry(agv._key, agv.vehicle.s, agv.vehicle.hull()))
        node.set_participant_factory(
            "voter",
            lambda: Voter(
                view=agv.node.view,
                recheck=agv.config.t_update / 2,
                blockers=agv._blockers,
                step_aside=agv._step_aside,
                revoked=agv.locking.revoked,
                tally=agv.tally,
            ),
        )
        node.set_participant_factory("bidder", lambda: Bidder(agv, tally=agv.tally))
        agv.peers = PeerWatch(
            book,
            node.view,
            top_speed_m_s=agv.spec.max_speed_m_s,
            max_hull_length_m=self.largest_hull_length(),
            count=self.count_distrust,
        )
        if agv.config.check_peers:
            node.set_property_check(agv.peers.check)
        node.register_node_departure_observer(self.departed)
        node.register_node_property_observer(self.peer_property, names=("hull_length",))
        node.update_node_property("kind", AGV_KIND)
        node.update_node_property("task", None)
        node.update_node_property("last_done", agv.last_done)
        node.update_node_property("reached_pick", None)
        node.update_node_property("dropping_at", None)
        agv.publish()

    def largest_hull_length(self) -> float:
        """The largest hull length a peer may publish on this layout (computed once)."""
        # Imported here: reach imports the controller's module.
        from agv_app.traffic.reach import largest_hull_length

        agv = self._agv
        if self._max_peer_hull is None:
            self._max_peer_hull = largest_hull_length(agv.layout, agv.spec, agv.config)
        return self._max_peer_hull

    def count_distrust(self, what: str) -> None:
        """Count one thing refused of a peer (``AgvController.distrust``)."""
        agv = self._agv
        agv.distrust[what] = agv.distrust.get(what, 0) + 1

    def departed(self, node_id: str, last: Mapping[str, Any]) -> None:
        """A peer left or failed: keep a stale record of an AGV's last circle."""
        agv = self._agv
        agv.peers.forget(node_id)
        if last.get("kind") != AGV_KIND:
            return
        pos, radius = last.get("position"), last.get("hull_length")
        if isinstance(pos, tuple | list) and isinstance(radius, int | float):
            agv.book.add_stale(StaleRecord(node_id, float(pos[0]), float(pos[1]), float(radius)))

    def peer_property(self, node_id: str, name: str, value: Any) -> None:
        """A peer published its hull length: it lives, its stale record goes."""
        agv = self._agv
        if node_id != agv.node_id and name == "hull_length":
            agv.book.drop_stale(node_id)

    def fail(self) -> None:
        """The node crashed, or the vehicle's driver failed: the vehicle is told to stop
        where it stands, and the AGV does nothing more."""
        agv = self._agv
        agv.failed = True
        agv.vehicle.stop()
        agv._requester = None

    def restart(self, node: RoleActivator) -> None:
        """Come back on a fresh node where the vehicle stands: forget the task (its
        station has returned it), finish the stretch it was on, then drive home."""
        agv = self._agv
        agv.task = None
        agv.pending_task = None
        agv._resume = None
        agv._done_later = None  # crashed before its dwell at the drop ended: not done
        agv._hold_until = 0.0
        agv.phase = "to_home" if agv._dest is not None else "lost"
        agv._requester = None
        agv._retry_at = 0.0
        agv.vehicle.clear_fault()
        agv.attach(node)
        agv._released_at_s = agv.vehicle.s

    def rest_when_parked(self) -> None:
        """Tell the node when the AGV parks at its home with no task, and when it stops:
        parked, it has nothing to say but that it lives, and beats less often."""
        agv = self._agv
        at_rest = (
            agv._dest is None
            and agv.phase == "home"
            and agv.point == agv.home
            and agv.task is None
            and agv.pending_task is None
        )
        if at_rest:
            agv.sent_home = False  # home: it takes tasks again
        if at_rest != self.at_rest:
            self.at_rest = at_rest
            agv.node.set_at_rest(at_rest)
