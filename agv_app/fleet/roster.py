"""Which AGVs of a mesh fleet are alive, which failed, and what the observer heard of each.

An AGV process fails when it exits while the fleet runs (``kill -9``, or any exit status
but 0) or when the observer stops hearing it (its node departs after the failure
timeout); one that exits with status 0 ended its run and has left (it is gone from the
vehicles and the nodes, and is no failure). A failed
AGV stays on the floor where it was last heard, as a vehicle with status ``failed``
and no locks (nobody honours them any more), so the operator sees the wreck and the
dashboard raises its alarm; its node leaves ``nodes()``. A node that departed and is
heard again (it was only late) is alive again; an exited process is failed for good.

:class:`AgvRoster` turns the observer's view into the dashboard's vehicles and node
stand-ins (:class:`~agv_app.fleet.remote.RemoteNode`) from one consistent look, so
``vehicles()`` and ``nodes()`` agree on who failed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from agv_app.fleet.observed import ObservedAgv, vehicle_state
from agv_app.fleet.remote import RemoteNode
from agv_app.fleet.view import VehicleState

__all__ = ["FAILED", "AgvRoster"]

FAILED = "failed"
"""The status of a failed AGV."""


class AgvRoster:
    """The AGVs of a mesh fleet as the observer hears them.

    Args:
        agv_ids: every AGV the fleet spawned; none when it joined a fleet that runs
            elsewhere: then every AGV heard is added as it is first heard.
        heard: the observer's view now: ``[(agv id, properties)]`` of the AGVs it hears.
        heard_one: one AGV's properties as ``heard`` gives them (None: not heard), read
            without the others: each node stand-in reads its own this way, so a look at
            every node costs one merge per node, not one per node and AGV.
        clock_offset: the fleet's start on the nodes' clock (see ``RemoteNode``).
    """

    def __init__(
        self,
        agv_ids: Sequence[str],
        heard: Callable[[], list[tuple[str, Mapping[str, Any]]]],
        heard_one: Callable[[str], Mapping[str, Any] | None],
        *,
        clock_offset: Callable[[], float],
    ) -> None:
        self.agv_ids = list(agv_ids)
        self._known = set(self.agv_ids)
        self._heard = heard
        self._heard_one = heard_one
        self._clock_offset = clock_offset
        self._observed: dict[str, ObservedAgv] = {}
        self._last: dict[str, VehicleState] = {}
        self._exited: set[str] = set()
        self._departed: set[str] = set()
        self._failed: dict[str, VehicleState] = {}
        self._gone: set[str] = set()
        self._left: set[str] = set()

    # -- what happened ----------------------------------------------------------------

    def exited(self, codes: Mapping[str, int | None]) -> None:
        """The processes' exit statuses by AGV id (None: running): 0 has left, any
        other has failed, for good."""
        for agv_id, code in codes.items():
            if code is None or agv_id not in self.agv_ids:
                continue
            (self._left if code == 0 else self._exited).add(agv_id)

    def departed(self, agv_id: str) -> None:
        """The observer stopped hearing this AGV (its node failed or left)."""
        if agv_id in self.agv_ids:
            self._departed.add(agv_id)

    # -- looking ----------------------------------------------------------------------

    def failed(self) -> list[str]:
        """Ids of the failed AGVs (heard or not before they failed), sorted."""
        self._refresh(self._heard())
        return sorted(self._gone)

    def vehicles(self) -> list[VehicleState]:
        """Every AGV heard, and every failed one where it was last heard, by id."""
        views = self._heard()
        self._refresh(views)
        out = {
            agv_id: self._state(agv_id, props)
            for agv_id, props in views
            if agv_id not in self._failed and agv_id not in self._left
        }
        out.update(self._failed)
        return [out[k] for k in sorted(out)]

    def nodes(self) -> dict[str, RemoteNode]:
        """A read-only stand-in for the node of every live AGV heard, by id."""
        views = self._heard()
        self._refresh(views)
        offset = self._clock_offset()
        return {
            agv_id: RemoteNode(agv_id, self._reader(agv_id), clock_offset=offset)
            for agv_id, _ in views
            if agv_id not in self._failed and agv_id not in self._left
        }

    def left(self) -> list[str]:
        """Ids of the AGVs whose process ended its run (exit status 0), sorted."""
        return sorted(self._left)

    def observed(self) -> Mapping[str, ObservedAgv]:
        """The decoded projections of every AGV seen (for the safety check)."""
        return self._observed

    # -- inside -----------------------------------------------------------------------

    def _reader(self, agv_id: str) -> Callable[[], Mapping[str, Any]]:
        def read() -> Mapping[str, Any]:
            return self._heard_one(agv_id) or {}

        return read

    def _state(self, agv_id: str, props: Mapping[str, Any]) -> VehicleState:
        seen = self._observed.get(agv_id)
        if seen is None:
            seen = self._observed[agv_id] = ObservedAgv()
        state = vehicle_state(agv_id, props, seen)
        self._last[agv_id] = state
        return state

    def _refresh(self, views: list[tuple[str, Mapping[str, Any]]]) -> None:
        heard = {agv_id for agv_id, _ in views}
        known = self._known
        for agv_id in sorted(heard - known):
            known.add(agv_id)
            self.agv_ids.append(agv_id)
        self._departed -= heard  # heard again: the departure was only lateness
        gone = self._gone = (self._exited | self._departed) - self._left
        for agv_id in gone - set(self._failed):
            last = self._last.get(agv_id)
            if last is None:
                props = dict(views).get(agv_id)
                last = None if props is None else self._state(agv_id, props)
            if last is not None:
                self._failed[agv_id] = dataclasses.replace(
                    last, status=FAILED, task_id=None, locked=(), requested=()
                )
        for agv_id in set(self._failed) - gone:
            del self._failed[agv_id]
