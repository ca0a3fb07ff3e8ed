"""What an AGV process shows the dashboard, sent to the observer alone.

An AGV process's display (its pose, the dashboard's finer ``state`` with the task it
belongs to, its size, its ``locked`` and ``requested`` projections, its ``route`` ahead,
and the ``sessions``, ``roles`` and ``traffic`` of its node) is read by the observer and
by nobody else. Published as node properties, every change was a frame to every node
that hears the AGV: on the demo floor every other AGV and the transport base, for a pose
twice a second. So the observer starts one session whose group is every AGV
(:func:`display_group`), each AGV plays :class:`DisplayReporter` in it, and the
display's changes go to the observer over that session's channel, reliable and in
order (:class:`DisplayFeed` on the AGV's side, :class:`DisplayCollector` on the
observer's). What the other nodes need stays a property: ``position`` and
``hull_length`` (its circle, at every request and release), ``status``, ``task``,
``last_done``, ``reached_pick`` and ``dropping_at``.

A reporter that joins gets the whole display at once; a send the channel refuses (its
buffer full) stays pending and goes with the next flush, merged with what changed
since: the observer wants the latest display, not every step of it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from agv_app.protocol import AGV_KIND
from objectplaces import Initiator, InitiatorRef, Participant, ParticipantRef, groups
from objectplaces.core.groups import GroupDefinition

__all__ = [
    "DISPLAY_FIELDS",
    "DISPLAY_ROLE",
    "DisplayCollector",
    "DisplayFeed",
    "DisplayReporter",
    "display_group",
]

DISPLAY_ROLE = "display"
"""The participant role an AGV plays in the observer's display session."""

DISPLAY_FIELDS = frozenset(
    {
        "position",
        "heading",
        "state",
        "speed",
        "held",
        "in_service",
        "loaded",
        "battery",
        "task",
        "size",
        "locked",
        "requested",
        "route",
        "sessions",
        "roles",
        "traffic",
    }
)
"""What a display report may carry; anything else a peer sends is left out."""


def display_group() -> GroupDefinition:
    """Every AGV: the display session's group."""
    return groups.property_equals("kind", AGV_KIND)


class DisplayReporter(Participant):
    """An AGV's role in the observer's display session: sends what its feed hands it."""

    def __init__(self, feed: DisplayFeed) -> None:
        self._feed = feed

    def in_group_of(self, initiator: InitiatorRef) -> None:
        self._feed.joined(self)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        self._feed.left(self)


class DisplayFeed:
    """The AGV's side: its display as last set, and what each reporter has yet to send.

    Register :meth:`reporter` as the node's participant factory for ``DISPLAY_ROLE``.
    """

    __slots__ = ("_last", "_pending")

    def __init__(self) -> None:
        self._last: dict[str, Any] = {}
        self._pending: dict[DisplayReporter, dict[str, Any]] = {}

    def reporter(self) -> DisplayReporter:
        """A new reporter for this feed (the participant factory)."""
        return DisplayReporter(self)

    def set(self, name: str, value: Any) -> None:
        """Show ``value`` as ``name``; sent with the next :meth:`flush` if it changed."""
        if self._last.get(name, self) == value:
            return
        self._last[name] = value
        for pending in self._pending.values():
            pending[name] = value

    def get(self, name: str) -> Any:
        """What ``name`` shows now (None if never set)."""
        return self._last.get(name)

    def flush(self) -> None:
        """Send every reporter what changed since its last send."""
        for reporter, pending in self._pending.items():
            if pending and reporter.send(pending):
                self._pending[reporter] = {}

    def joined(self, reporter: DisplayReporter) -> None:
        """``reporter`` was activated: it owes the whole display."""
        self._pending[reporter] = dict(self._last)
        self.flush()

    def left(self, reporter: DisplayReporter) -> None:
        """``reporter`` was deactivated: it sends nothing more."""
        self._pending.pop(reporter, None)


class DisplayCollector(Initiator):
    """The observer's side: the latest display of every AGV in its session.

    Args:
        on_report: called with the AGV's id and what it just reported (known fields
            only), after the report is stored.
    """

    def __init__(self, on_report: Callable[[str, Mapping[str, Any]], None] | None = None) -> None:
        self.reports: dict[str, dict[str, Any]] = {}
        """What each AGV last showed, by node id (only fields of ``DISPLAY_FIELDS``)."""
        self.refused = 0
        """Reports that were not a mapping (a peer's bad input, left out)."""
        self._on_report = on_report

    def receive(self, participant: ParticipantRef, message: Any) -> None:
        if not isinstance(message, Mapping):
            self.refused += 1
            return
        known = {k: v for k, v in message.items() if isinstance(k, str) and k in DISPLAY_FIELDS}
        if "position" in known:
            position = known["position"]
            # As the property view holds a position: a tuple (the wire makes it a list).
            two = isinstance(position, list | tuple) and len(position) == 2
            known["position"] = tuple(position) if two else None
        self.reports.setdefault(participant.node_id, {}).update(known)
        if self._on_report is not None and known:
            self._on_report(participant.node_id, known)

    def out_group(self, participant: ParticipantRef) -> None:
        self.reports.pop(participant.node_id, None)

    def shown(self, node_id: str, properties: Mapping[str, Any]) -> Mapping[str, Any]:
        """``properties`` of ``node_id`` as the observer holds them, with its display
        over them (what a display field leaves out, such as a malformed position,
        falls back to the property)."""
        report = self.reports.get(node_id)
        if not report:
            return properties
        merged = dict(properties)
        merged.update((k, v) for k, v in report.items() if v is not None)
        return merged
