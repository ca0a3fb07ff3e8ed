"""The operator's log: events with a severity, and alarms that stay active until cleared.

Pure bookkeeping: every input carries ``now`` (simulated seconds), nothing here reads a
clock. Memory is bounded: the last ``history`` events are kept (older ones are dropped,
and counted), and at most one active alarm per key (a key names what the alarm is about,
e.g. ``waiting:agv-3``), so an alarm raised again while active is not repeated.

Given a store (``EventStore``; the control's :class:`~agv_app.tasks.store.OrderStore`),
every event is also written there, and a new log on the same store starts with the
events it kept and numbers on from them. Alarms are not kept: they are conditions of the
running fleet, raised again by whoever watches it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Literal, Protocol

__all__ = [
    "DEFAULT_HISTORY",
    "SEVERITIES",
    "Alarm",
    "Event",
    "EventLog",
    "EventStore",
    "Severity",
]

Severity = Literal["info", "warning", "alarm"]
"""How much an event asks of the operator: nothing, a look, an action."""

SEVERITIES: tuple[Severity, ...] = ("info", "warning", "alarm")
"""Every severity, least first."""

DEFAULT_HISTORY = 1000
"""How many events a log keeps by default."""


@dataclass(frozen=True, slots=True)
class Event:
    """One line of the log.

    Attributes:
        seq: its number in the log (0, 1, 2 …, never reused).
        time: simulated seconds.
        severity: how much it asks of the operator.
        source: what it is about (a node id, ``fleet``, ``api``).
        text: what happened, in words.
    """

    seq: int
    time: float
    severity: Severity
    source: str
    text: str


@dataclass(frozen=True, slots=True)
class Alarm:
    """A condition that holds until it is cleared.

    Attributes:
        key: what it is about, unique among active alarms.
        event: the event that raised it (its time is when the condition began).
    """

    key: str
    event: Event


class EventStore(Protocol):
    """Where a log's events outlive the process (times on the fleet's clock)."""

    def add_event(self, seq: int, time: float, severity: str, source: str, text: str) -> None:
        """Keep one event."""
        ...

    def recent_events(self, limit: int) -> list[tuple[int, float, str, str, str]]:
        """The last ``limit`` events kept, oldest first: seq, time, severity, source, text."""
        ...


class EventLog:
    """Events, newest last, and the active alarms.

    Args:
        history: how many events to keep (at least 1).
        store: where every event is written, and the events the log starts with.

    Raises:
        ValueError: ``history`` is less than 1.
    """

    def __init__(self, *, history: int = DEFAULT_HISTORY, store: EventStore | None = None) -> None:
        if history < 1:
            raise ValueError(f"history must be 1 or more, got {history!r}")
        self._events: deque[Event] = deque(maxlen=history)
        self._alarms: dict[str, Alarm] = {}
        self._seq = 0
        self.dropped = 0
        """Events no longer kept because the history was full."""
        self.store = store
        if store is not None:
            for seq, time, severity, source, text in store.recent_events(history):
                if severity in SEVERITIES:
                    self._events.append(Event(seq, time, severity, source, text))
            if self._events:
                self._seq = self._events[-1].seq + 1
                self.dropped = self._events[0].seq  # numbered from 0, none reused

    @property
    def events(self) -> list[Event]:
        """The events kept, oldest first."""
        return list(self._events)

    @property
    def alarms(self) -> list[Alarm]:
        """The active alarms, most severe first, then oldest first."""
        return sorted(
            self._alarms.values(),
            key=lambda a: (-SEVERITIES.index(a.event.severity), a.event.seq),
        )

    def record(self, now: float, severity: Severity, source: str, text: str) -> Event:
        """Add one event."""
        event = Event(self._seq, float(now), severity, source, text)
        self._seq += 1
        if len(self._events) == self._events.maxlen:
            self.dropped += 1
        self._events.append(event)
        if self.store is not None:
            self.store.add_event(event.seq, event.time, severity, source, text)
        return event

    def raise_alarm(
        self, key: str, now: float, source: str, text: str, *, severity: Severity = "alarm"
    ) -> bool:
        """Raise the alarm ``key`` (and log it) unless it is active already; True if raised."""
        if key in self._alarms:
            return False
        self._alarms[key] = Alarm(key, self.record(now, severity, source, text))
        return True

    def clear_alarm(self, key: str, now: float, text: str) -> bool:
        """Clear the alarm ``key`` and log ``text`` as info; False if it was not active."""
        alarm = self._alarms.pop(key, None)
        if alarm is None:
            return False
        self.record(now, "info", alarm.event.source, text)
        return True

    def clear_alarms_of(self, source: str, now: float, text: str) -> int:
        """Clear every alarm about ``source`` (e.g. a node that left); how many."""
        keys = [k for k, a in self._alarms.items() if a.event.source == source]
        for key in keys:
            self.clear_alarm(key, now, text)
        return len(keys)
