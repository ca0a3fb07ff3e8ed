"""What the dashboard knows besides the fleet: sessions it started, feed clients, caches.

``DashboardState`` is touched only from the app's event loop (handlers and the fleet
driver alike; see ``dashboard.app``), so it needs no locks. Reads never change it: the
sessions that ended are forgotten by the driver (``prune``), not by whoever looks.
Everything it holds is bounded: sessions started over HTTP by ``MAX_API_SESSIONS``, feed
clients by the connections open, caches by what is live now.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import Any

from fastapi import HTTPException

from dashboard import introspect
from dashboard.capture import JSON, FleetState, PolygonCache, SessionRecord, capture, layout_json
from dashboard.clock import RunClock
from dashboard.eventlog import EventLog
from dashboard.feed import ClientFeed, FeedHub
from dashboard.limits import shown
from dashboard.membership import MembershipHistory
from dashboard.poll import POLL_ROLE, RESPONDER_ROLE, PollResponder, poll_factory
from dashboard.schemas import SimOut
from dashboard.source import FleetSource, InitiatorFactory, NodeHandle
from dashboard.stopping import fleet_stop_asked, stop_state
from dashboard.watch import FleetWatch
from objectplaces import Initiator, Session

__all__ = ["MAX_API_SESSIONS", "ApiSession", "ApiSessions", "DashboardState", "FeedClient"]

MAX_API_SESSIONS = 256
"""Most sessions started over HTTP that may be live at once."""


@dataclass(frozen=True, slots=True)
class ApiSession:
    """A session started through ``POST /api/sessions``."""

    node: str
    role: str
    handle: Session
    initiator: Initiator
    params: dict[str, Any]


class ApiSessions:
    """The sessions started over HTTP, by session id; at most ``limit`` at once.

    Args:
        limit: how many may be registered at once.
    """

    def __init__(self, *, limit: int = MAX_API_SESSIONS) -> None:
        self.limit = limit
        self._sessions: dict[str, ApiSession] = {}

    def __len__(self) -> int:
        """Number registered."""
        return len(self._sessions)

    def __contains__(self, session_id: object) -> bool:
        """True when ``session_id`` was started over HTTP and not yet forgotten."""
        return session_id in self._sessions

    def __iter__(self) -> Iterator[str]:
        """The registered session ids, oldest first."""
        return iter(list(self._sessions))

    @property
    def full(self) -> bool:
        """True when no further session may be registered."""
        return len(self._sessions) >= self.limit

    def values(self) -> list[ApiSession]:
        """The registered sessions, oldest first."""
        return list(self._sessions.values())

    def get(self, session_id: str) -> ApiSession | None:
        """The registered session, or None."""
        return self._sessions.get(session_id)

    def add(self, session_id: str, session: ApiSession) -> None:
        """Register a session just started.

        Raises:
            OverflowError: ``limit`` sessions are registered already.
        """
        if self.full and session_id not in self._sessions:
            raise OverflowError(f"already {self.limit} sessions started over HTTP")
        self._sessions[session_id] = session

    def pop(self, session_id: str) -> ApiSession | None:
        """Forget a session; the forgotten record, or None."""
        return self._sessions.pop(session_id, None)

    def prune(self, live: Callable[[str], bool]) -> list[str]:
        """Forget every session for which ``live(session_id)`` is false.

        Returns:
            The ids forgotten.
        """
        gone = [sid for sid in self._sessions if not live(sid)]
        for sid in gone:
            del self._sessions[sid]
        return gone


@dataclass(frozen=True, slots=True)
class FeedClient:
    """One connected feed client: its mailbox and the event that wakes its sender."""

    handle: int
    feed: ClientFeed
    wake: asyncio.Event


class DashboardState:
    """The fleet and what the dashboard keeps beside it.

    Args:
        source: the running fleet.
        events: the operator's log (default: a new one, in memory only).
    """

    def __init__(self, source: FleetSource, *, events: EventLog | None = None) -> None:
        self.source = source
        self.layout: JSON = layout_json(source.layout_view())
        self.api = ApiSessions()
        self.hub = FeedHub()
        self._wakers: dict[int, asyncio.Event] = {}
        self._responders_on: set[str] = set()
        self._polygons = PolygonCache()
        self._last_counters: dict[str, dict[str, Any]] | None = None
        self.events = EventLog() if events is None else events
        """The operator's log (``GET /api/events``)."""
        self.watch = FleetWatch(self.events)
        self.clock = RunClock()
        """Wall time run and simulated time gained, measured by the driver."""
        self.memberships = MembershipHistory()
        """Joins and leaves per session, seen at every publication (``publish``)."""

    # ---- reading ----------------------------------------------------------------------

    def roles(self) -> dict[str, InitiatorFactory]:
        """Initiator roles startable over HTTP: the fleet's, and ``poll``."""
        roles: dict[str, InitiatorFactory] = dict(self.source.initiator_roles())
        roles[POLL_ROLE] = poll_factory
        return roles

    def node(self, node_id: str, *, status: int = 404) -> NodeHandle:
        """The node handle, or an HTTP error naming the unknown id.

        Args:
            node_id: the node's id.
            status: the HTTP status of the error (404 in a path, 422 in a body).
        """
        nodes = self.source.nodes()
        if node_id not in nodes:
            known = ", ".join(sorted(nodes)[:8])
            more = ", ..." if len(nodes) > 8 else ""
            raise HTTPException(status, f"unknown node {shown(node_id)} (known: {known}{more})")
        return nodes[node_id]

    def fixed_positions(self) -> dict[str, list[float]]:
        """Where the nodes that are not vehicles stand (the transport base), for session
        lines."""
        vehicles = {v.id for v in self.source.vehicles()}
        out: dict[str, list[float]] = {}
        for node_id, node in sorted(self.source.nodes().items()):
            pos = node.properties.get("position")
            if node_id in vehicles or not isinstance(pos, tuple | list) or len(pos) != 2:
                continue
            if all(isinstance(c, int | float) and math.isfinite(c) for c in pos):
                out[node_id] = [float(pos[0]), float(pos[1])]
        return out

    def sessions(self) -> dict[str, SessionRecord]:
        """Every live session on every node, by id; those started over HTTP say so."""
        records: dict[str, SessionRecord] = {}
        for node_id, node in self.source.nodes().items():
            for rec in introspect.sessions_of(node_id, node):
                api = self.api.get(rec.session_id)
                # The node knows the role's class; the API knows the name it started under.
                records[rec.session_id] = rec if api is None else rec.started_over_http(api.role)
        return records

    def sim(self) -> SimOut:
        """The clock state."""
        s = self.source
        return SimOut(
            now=float(s.now),
            paused=bool(s.paused),
            speed=float(s.speed),
            stop=stop_state(fleet_stop_asked(s), s.vehicles()),
        )

    # ---- changing (the driver and mutating handlers) ---------------------------------

    def ensure_responders(self) -> None:
        """Register the poll responder on every node that does not have it yet; forget
        nodes that left."""
        nodes = self.source.nodes()
        self._responders_on.intersection_update(nodes)
        for node_id, node in nodes.items():
            if node_id in self._responders_on:
                continue
            node.set_participant_factory(RESPONDER_ROLE, _responder_factory(node))
            self._responders_on.add(node_id)

    def watch_fleet(self) -> None:
        """Log what changed in the fleet since the last look (``dashboard.watch``)."""
        source = self.source
        self.watch.observe(
            float(source.now),
            nodes=set(source.nodes()),
            statuses={v.id: v.status for v in source.vehicles()},
            paused=bool(source.paused),
        )

    def prune(self) -> list[str]:
        """Forget sessions started over HTTP that have ended (by themselves, or on a node
        that left); the ids forgotten."""
        nodes = self.source.nodes()
        live: set[str] = set()
        for node_id in {api.node for api in self.api.values()}:
            node = nodes.get(node_id)
            if node is not None:
                live.update(str(info.session_id) for info in node.sessions())
        return self.api.prune(live.__contains__)

    def counters(self, *, fresh: bool = True) -> dict[str, dict[str, Any]]:
        """Per-node message and byte counters, by node id.

        Args:
            fresh: read the nodes; otherwise reuse the last reading when there is one
                (the feed sends counters only every half second anyway).
        """
        if fresh or self._last_counters is None:
            self._last_counters = {
                node_id: introspect.counters_of(node)
                for node_id, node in self.source.nodes().items()
            }
        return self._last_counters

    def metrics(self) -> dict[str, float]:
        """The fleet's figures, with ``wall_seconds`` and ``sim_speed`` as measured live."""
        return {
            **{str(k): float(v) for k, v in self.source.metrics().items()},
            **self.clock.figures(),
        }

    def capture(
        self, *, fresh_counters: bool = True, sessions: dict[str, SessionRecord] | None = None
    ) -> FleetState:
        """The fleet as the feed shows it now (metrics as ``metrics()``); ``sessions``
        when the caller has just read them."""
        state = capture(
            self.source,
            sessions=self.sessions() if sessions is None else sessions,
            nodes=self.counters(fresh=fresh_counters),
            cache=self._polygons,
        )
        return replace(state, metrics={**state.metrics, **self.clock.figures()})

    def connect_feed(self) -> FeedClient:
        """Register a feed client and offer it the current state."""
        feed = ClientFeed(dict(self.layout, nodes=self.fixed_positions()))
        handle = self.hub.add(feed)
        client = FeedClient(handle, feed, asyncio.Event())
        self._wakers[handle] = client.wake
        feed.offer(self.capture())
        return client

    def disconnect_feed(self, client: FeedClient) -> None:
        """Forget a feed client (no error when already gone)."""
        self.hub.remove(client.handle)
        self._wakers.pop(client.handle, None)

    def publish(self, *, fresh_counters: bool = True) -> None:
        """Note who joined and left each session, then offer the current state to every
        feed client and wake their senders."""
        sessions = self.sessions()
        self.memberships.observe(float(self.source.now), sessions)
        if not len(self.hub):
            return
        self.hub.publish(self.capture(fresh_counters=fresh_counters, sessions=sessions))
        for event in self._wakers.values():
            event.set()


def _responder_factory(node: NodeHandle) -> Callable[[], PollResponder]:
    return lambda: PollResponder(lambda: node.properties)
