"""Stall watch: an AGV that wants to move and has not moved for too long is deadlocked.

Deadlock avoidance (:mod:`agv_app.traffic.deadlock`) should make this impossible; the
watch is how a run proves it. Both fleets count with it: the simulated one from each
controller, the mesh one from the state each AGV process publishes.

Short of a deadlock, long waits show traffic that flows badly: the watch also counts
the waits that last over :data:`LONG_WAIT_S` (each wait once, however long) and keeps
the longest single wait.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["LONG_WAIT_S", "STALL_LIMIT_S", "StallWatch"]

STALL_LIMIT_S = 180.0
"""Seconds an AGV may wait to move before it counts as deadlocked."""

LONG_WAIT_S = 60.0
"""Seconds of one wait past which it counts as a long wait (``stalls_60s``)."""


class StallWatch:
    """Counts AGVs that stay stalled longer than ``limit_s``, each stall once.

    Args:
        limit_s: seconds of waiting that count as a deadlock.
        long_wait_s: seconds of waiting that count as a long wait.
        on_long_wait: told of each wait as it passes ``long_wait_s``: the AGV, the time
            (the task desk's limit that follows the floor listens).
    """

    def __init__(
        self,
        *,
        limit_s: float = STALL_LIMIT_S,
        long_wait_s: float = LONG_WAIT_S,
        on_long_wait: Callable[[str, float], None] | None = None,
    ) -> None:
        self.limit_s = limit_s
        self.long_wait_s = long_wait_s
        self.on_long_wait = on_long_wait
        self.deadlocks = 0
        """Stalls that lasted longer than the limit."""
        self.long_waits = 0
        """Waits that lasted longer than ``long_wait_s``, each counted once."""
        self.max_wait = 0.0
        """The longest single wait so far (one still going on included), seconds."""
        self._since: dict[str, float] = {}
        self._counted: set[str] = set()
        self._long: set[str] = set()

    def observe(self, agv_id: str, *, stalled: bool, now: float) -> None:
        """Whether ``agv_id`` waits to move at ``now`` (call it at every check)."""
        if not stalled:
            self._since.pop(agv_id, None)
            self._counted.discard(agv_id)
            self._long.discard(agv_id)
            return
        since = self._since.setdefault(agv_id, now)
        waited = now - since
        self.max_wait = max(self.max_wait, waited)
        if waited > self.long_wait_s and agv_id not in self._long:
            self._long.add(agv_id)
            self.long_waits += 1
            if self.on_long_wait is not None:
                self.on_long_wait(agv_id, now)
        if waited > self.limit_s and agv_id not in self._counted:
            self._counted.add(agv_id)
            self.deadlocks += 1

    def stalled_for(self, agv_id: str, now: float) -> float:
        """Seconds ``agv_id`` has been waiting to move (0 if it is not)."""
        since = self._since.get(agv_id)
        return 0.0 if since is None else now - since
