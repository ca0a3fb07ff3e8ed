"""Watches the fleet between two steps and writes what changed into the operator's log.

:class:`FleetWatch` compares what it sees now with what it saw last time: nodes that
joined or left, vehicles that failed or recovered or ran empty, vehicles waiting too
long, and a pause or resume the dashboard did not ask for. Pure: the caller passes what
it reads from the fleet and ``now``.
"""

from __future__ import annotations

from collections.abc import Mapping, Set

from dashboard.eventlog import EventLog

__all__ = ["WAITING_ALARM_S", "FleetWatch"]

WAITING_ALARM_S = 60.0
"""Simulated seconds an AGV may wait before its wait is an alarm."""


class FleetWatch:
    """Turns successive looks at the fleet into events and alarms.

    Args:
        log: where events and alarms go.
        waiting_alarm_s: how long a vehicle may wait before the alarm.
    """

    def __init__(self, log: EventLog, *, waiting_alarm_s: float = WAITING_ALARM_S) -> None:
        self.log = log
        self.waiting_alarm_s = waiting_alarm_s
        self._nodes: set[str] | None = None
        self._status: dict[str, str] = {}
        self._waiting_since: dict[str, float] = {}
        self._paused: bool | None = None

    def observe(
        self, now: float, *, nodes: Set[str], statuses: Mapping[str, str], paused: bool
    ) -> None:
        """One look at the fleet.

        Args:
            now: simulated seconds.
            nodes: every node id.
            statuses: every vehicle's status by id (``failed``, ``waiting``, …).
            paused: whether the fleet is paused.
        """
        self._nodes_changed(now, nodes)
        for vid, status in statuses.items():
            self._status_changed(now, vid, status)
        for vid in set(self._status) - set(statuses):
            del self._status[vid]
            self._waiting_since.pop(vid, None)
        if self._paused is not None and paused != self._paused:
            self.log.record(
                now,
                "warning" if paused else "info",
                "fleet",
                "fleet paused by itself" if paused else "fleet resumed by itself",
            )
        self._paused = paused

    def waiting_since(self, vehicle_id: str) -> float | None:
        """When the vehicle began to wait (as first seen waiting), or None if it does not."""
        return self._waiting_since.get(vehicle_id)

    def paused(self, now: float, paused: bool, why: str) -> None:
        """The dashboard paused or resumed the fleet, for ``why``: log it as asked."""
        word = "paused" if paused else "resumed"
        self.log.record(now, "warning" if paused else "info", "fleet", f"fleet {word}: {why}")
        self._paused = paused

    def _nodes_changed(self, now: float, nodes: Set[str]) -> None:
        if self._nodes is None:
            self.log.record(now, "info", "fleet", f"watching {len(nodes)} nodes")
            self._nodes = set(nodes)
            return
        for node in sorted(nodes - self._nodes):
            self.log.record(now, "info", node, f"node {node} joined")
        for node in sorted(self._nodes - nodes):
            self.log.record(now, "warning", node, f"node {node} left")
            self.log.clear_alarms_of(node, now, f"alarms of {node} cleared: it left")
        self._nodes = set(nodes)

    def _status_changed(self, now: float, vid: str, status: str) -> None:
        before = self._status.get(vid)
        self._status[vid] = status
        if status == "empty" and before != "empty":
            self.log.raise_alarm(
                f"empty:{vid}", now, vid, f"{vid} ran empty: stopped where it stands"
            )
        if status == "failed" and before != "failed":
            self.log.raise_alarm(f"failed:{vid}", now, vid, f"{vid} failed")
        elif before == "failed" and status != "failed":
            self.log.clear_alarm(f"failed:{vid}", now, f"{vid} recovered ({status})")
        if status != "waiting":
            since = self._waiting_since.pop(vid, None)
            if since is not None:
                self.log.clear_alarm(
                    f"waiting:{vid}", now, f"{vid} moves on after waiting {now - since:.0f} s"
                )
            return
        since = self._waiting_since.setdefault(vid, now)
        if now - since >= self.waiting_alarm_s:
            self.log.raise_alarm(
                f"waiting:{vid}",
                now,
                vid,
                f"{vid} waiting for over {self.waiting_alarm_s:.0f} s (since {since:.1f} s)",
                severity="warning",
            )
