"""Stall watch: an AGV that wants to move and has not moved for too long is deadlocked.

Deadlock avoidance (:mod:`agv_app.traffic.deadlock`) should make this impossible; the
watch is how a run proves it. Both fleets count with it: the simulated one from each
controller, the mesh one from the state each AGV process publishes.
"""

from __future__ import annotations

__all__ = ["STALL_LIMIT_S", "StallWatch"]

STALL_LIMIT_S = 180.0
"""Seconds an AGV may wait to move before it counts as deadlocked."""


class StallWatch:
    """Counts AGVs that stay stalled longer than ``limit_s``, each stall once.

    Args:
        limit_s: seconds of waiting that count as a deadlock.
    """

    def __init__(self, *, limit_s: float = STALL_LIMIT_S) -> None:
        self.limit_s = limit_s
        self.deadlocks = 0
        """Stalls that lasted longer than the limit."""
        self._since: dict[str, float] = {}
        self._counted: set[str] = set()

    def observe(self, agv_id: str, *, stalled: bool, now: float) -> None:
        """Whether ``agv_id`` waits to move at ``now`` (call it at every check)."""
        if not stalled:
            self._since.pop(agv_id, None)
            self._counted.discard(agv_id)
            return
        since = self._since.setdefault(agv_id, now)
        if now - since > self.limit_s and agv_id not in self._counted:
            self._counted.add(agv_id)
            self.deadlocks += 1

    def stalled_for(self, agv_id: str, now: float) -> float:
        """Seconds ``agv_id`` has been waiting to move (0 if it is not)."""
        since = self._since.get(agv_id)
        return 0.0 if since is None else now - since
