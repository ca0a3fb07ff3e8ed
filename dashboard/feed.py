"""The event feed behind ``WS /ws/events``, as pure logic (no I/O, no clock).

A ``FleetState`` (``dashboard.capture``) is one picture of everything the page shows.
Each connected client has a ``ClientFeed`` that holds the newest state offered to it (a
slot of size one: a newer state replaces an unsent one, so a slow client gets the latest
picture, never a backlog) and the state it last sent. ``take(now)`` turns the pending
state into the next message: a full ``snapshot`` first, then ``delta`` messages carrying
only what changed, at most once per ``min_interval`` (20 a second by default). Per-node
counters change on every message, so they ride along at most every ``nodes_interval``.

The message format is documented in ``docs/dashboard.md``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from dashboard.capture import COORD_DIGITS, JSON, FleetState, finite_or_none

__all__ = ["ClientFeed", "FeedHub", "diff", "snapshot_message"]

# Fields of a vehicle record that are lock state; the rest is pose and status.
_LOCK_FIELDS = ("locked", "requested")


def _metrics_json(metrics: Mapping[str, float]) -> JSON:
    return {k: finite_or_none(v) for k, v in sorted(metrics.items())}


def snapshot_message(state: FleetState, layout: JSON, *, seq: int = 0) -> JSON:
    """The full picture a client gets first.

    Args:
        state: the state to show.
        layout: ``layout_json`` of the fleet's layout.
        seq: the message's sequence number on this connection.

    Returns:
        A ``{"type": "snapshot", ...}`` message.
    """
    return {
        "type": "snapshot",
        "seq": seq,
        "now": round(state.now, COORD_DIGITS),
        "sim": {"paused": state.paused, "speed": state.speed, "stop": state.stop},
        "layout": layout,
        "vehicles": {k: state.vehicles[k] for k in sorted(state.vehicles)},
        "sessions": [state.sessions[k].as_json() for k in sorted(state.sessions)],
        "nodes": {k: state.nodes[k] for k in sorted(state.nodes)},
        "metrics": _metrics_json(state.metrics),
    }


def diff(old: FleetState, new: FleetState, *, include_nodes: bool = True) -> JSON:
    """What changed from ``old`` to ``new``, as the body of a delta message.

    Args:
        old: the state the client already has.
        new: the state to bring it to.
        include_nodes: whether to compare per-node counters at all.

    Returns:
        Only the non-empty keys among ``sim, vehicles, vehicles_removed, locks,
        sessions_started, sessions_stopped, members, metrics, nodes, nodes_removed``;
        an empty dict when nothing changed (time alone does not count).
    """
    out: JSON = {}
    if (old.paused, old.speed, old.stop) != (new.paused, new.speed, new.stop):
        out["sim"] = {"paused": new.paused, "speed": new.speed, "stop": new.stop}

    vehicles: JSON = {}
    locks: JSON = {}
    for vid in sorted(new.vehicles):
        cur = new.vehicles[vid]
        prev = old.vehicles.get(vid)
        if prev is None:
            vehicles[vid] = {k: v for k, v in cur.items() if k not in _LOCK_FIELDS}
            locks[vid] = {k: cur[k] for k in _LOCK_FIELDS}
            continue
        changed = {k: v for k, v in cur.items() if k not in _LOCK_FIELDS and prev.get(k) != v}
        if changed:
            vehicles[vid] = changed
        if any(prev.get(k) != cur[k] for k in _LOCK_FIELDS):
            locks[vid] = {k: cur[k] for k in _LOCK_FIELDS}
    if vehicles:
        out["vehicles"] = vehicles
    if locks:
        out["locks"] = locks
    removed = sorted(set(old.vehicles) - set(new.vehicles))
    if removed:
        out["vehicles_removed"] = removed

    started = [new.sessions[s].as_json() for s in sorted(new.sessions) if s not in old.sessions]
    stopped = sorted(s for s in old.sessions if s not in new.sessions)
    members = {
        s: sorted(new.sessions[s].members)
        for s in sorted(new.sessions)
        if s in old.sessions and set(old.sessions[s].members) != set(new.sessions[s].members)
    }
    if started:
        out["sessions_started"] = started
    if stopped:
        out["sessions_stopped"] = stopped
    if members:
        out["members"] = members

    metrics = {
        k: finite_or_none(v)
        for k, v in sorted(new.metrics.items())
        if k not in old.metrics or old.metrics[k] != v
    }
    if metrics:
        out["metrics"] = metrics

    if include_nodes:
        nodes = {k: v for k, v in sorted(new.nodes.items()) if old.nodes.get(k) != v}
        if nodes:
            out["nodes"] = nodes
        gone = sorted(set(old.nodes) - set(new.nodes))
        if gone:
            out["nodes_removed"] = gone
    return out


class ClientFeed:
    """One client's view of the feed: a one-slot mailbox plus what it last received.

    Args:
        layout: ``layout_json`` of the fleet's layout, sent once in the snapshot.
        min_interval: least time between two messages, in seconds (0.05: 20 a second).
        nodes_interval: least time between two updates of per-node counters.
    """

    def __init__(
        self, layout: JSON, *, min_interval: float = 0.05, nodes_interval: float = 0.5
    ) -> None:
        self._layout = layout
        self.min_interval = min_interval
        self.nodes_interval = nodes_interval
        self._pending: FleetState | None = None
        self._sent: FleetState | None = None
        self._sent_at: float | None = None
        self._nodes_sent_at: float | None = None
        self._seq = 0
        self.offered = 0
        """States offered so far (for tests and the nodes panel)."""
        self.coalesced = 0
        """Offered states replaced before they were sent."""

    @property
    def has_pending(self) -> bool:
        """True when a state waits to be sent."""
        return self._pending is not None

    def offer(self, state: FleetState) -> None:
        """Make ``state`` the one to send next, replacing any unsent one.

        Args:
            state: the newest fleet state.
        """
        if self._pending is not None:
            self.coalesced += 1
        self._pending = state
        self.offered += 1

    def delay(self, now: float) -> float | None:
        """Seconds to wait before ``take`` may send, or None when nothing is pending.

        Args:
            now: the current time on the caller's clock.
        """
        if self._pending is None:
            return None
        if self._sent_at is None:
            return 0.0
        wait = self._sent_at + self.min_interval - now
        # Tolerate float rounding so a caller ticking at exact multiples is not skipped.
        return 0.0 if wait <= 1e-9 else wait

    def take(self, now: float) -> JSON | None:
        """The next message to send, or None (nothing pending, too soon, or no change).

        The first message is a snapshot; later ones are deltas against what this client
        last received, so states dropped in between are folded in, not lost.

        Args:
            now: the current time on the caller's clock (the same clock each call).
        """
        wait = self.delay(now)
        if wait is None or wait > 0.0:
            return None
        state = self._pending
        assert state is not None
        self._pending = None
        if self._sent is None:
            self._sent, self._sent_at, self._nodes_sent_at = state, now, now
            message = snapshot_message(state, self._layout, seq=self._seq)
            self._seq += 1
            return message
        nodes_due = self._nodes_sent_at is None or now - self._nodes_sent_at >= self.nodes_interval
        body = diff(self._sent, state, include_nodes=nodes_due)
        if not nodes_due:
            # Keep the counters the client actually has, so the next due update
            # carries everything that changed meanwhile.
            state = dataclasses.replace(state, nodes=self._sent.nodes)
        elif "nodes" in body or "nodes_removed" in body:
            self._nodes_sent_at = now
        self._sent = state
        if not body:
            return None
        self._sent_at = now
        message = {"type": "delta", "seq": self._seq, "now": round(state.now, COORD_DIGITS)}
        message.update(body)
        self._seq += 1
        return message


class FeedHub:
    """Every connected client's ``ClientFeed``; a new state is offered to all at once."""

    def __init__(self) -> None:
        self._clients: dict[int, ClientFeed] = {}
        self._next_id = 0

    def __len__(self) -> int:
        """Number of connected clients."""
        return len(self._clients)

    def add(self, client: ClientFeed) -> int:
        """Register a client.

        Returns:
            A handle for ``remove``.
        """
        handle = self._next_id
        self._next_id += 1
        self._clients[handle] = client
        return handle

    def remove(self, handle: int) -> None:
        """Forget a client (no error when already gone)."""
        self._clients.pop(handle, None)

    def publish(self, state: FleetState) -> None:
        """Offer ``state`` to every client."""
        for client in self._clients.values():
            client.offer(state)
