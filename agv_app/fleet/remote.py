"""A node that runs in another process, as the observer hears it: reads only.

An AGV process shows the observer, beside what draws it, what the dashboard shows of
any node: the sessions it initiated (``sessions``), the participant roles it plays
(``roles``) and its traffic by kind (``traffic``), in the plain forms
:func:`sessions_wire`, :func:`roles_wire` and :func:`traffic_wire` give, over the
observer's display session (:mod:`agv_app.fleet.display_feed`). :class:`RemoteNode`
reads them back from what the observer holds of the AGV and answers the dashboard's
reading members as a local ``RoleActivator`` would; the members that would act on the
node (start or stop a session, evaluate a group from its point of view) raise
``LocalProtocolError``, since the node's own process alone can do that.

Times: an AGV's node clock is the machine's monotonic clock (its event loop's), as is
the observer's; every process of a mesh fleet runs on this machine (127.0.0.1), so a
``started_at`` is turned into the fleet's time by subtracting the fleet's start.
The wire forms are bounded: at most ``MAX_SESSIONS`` sessions and ``MAX_ROLES`` roles.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from objectplaces import (
    Initiator,
    LocalProtocolError,
    NodeStats,
    Participant,
    ParticipationInfo,
    Session,
    SessionInfo,
)
from objectplaces.core.groups import DefinitionLike

__all__ = [
    "INTROSPECTION_PROPERTIES",
    "MAX_ROLES",
    "MAX_SESSIONS",
    "RemoteNode",
    "roles_wire",
    "sessions_wire",
    "traffic_wire",
]

MAX_SESSIONS = 32
"""Most sessions one node publishes (the newest)."""

MAX_ROLES = 64
"""Most participant roles one node publishes (the newest)."""

INTROSPECTION_PROPERTIES = frozenset({"sessions", "roles", "traffic"})
"""Properties that carry introspection, not state: shown in their own fields."""


def sessions_wire(sessions: list[SessionInfo]) -> list[list[Any]]:
    """The newest sessions as ``[id, initiator role, participant role, [members],
    started_at, definition]``."""
    newest = sorted(sessions, key=lambda s: s.started_at)[-MAX_SESSIONS:]
    return [
        [
            str(s.session_id),
            str(s.initiator_role),
            str(s.participant_role),
            sorted(s.members),
            round(float(s.started_at), 3),
            s.definition,
        ]
        for s in newest
    ]


def roles_wire(participations: list[ParticipationInfo]) -> list[list[Any]]:
    """The newest participant roles as ``[session id, initiator, role, since]``."""
    newest = sorted(participations, key=lambda p: p.since)[-MAX_ROLES:]
    return [
        [str(p.session_id), str(p.initiator), str(p.participant_role), round(float(p.since), 3)]
        for p in newest
    ]


def traffic_wire(stats: NodeStats) -> dict[str, dict[str, list[int]]]:
    """Frames and bytes sent and received, by kind."""
    return {
        "sent": {k: [int(v[0]), int(v[1])] for k, v in stats.sent.items()},
        "received": {k: [int(v[0]), int(v[1])] for k, v in stats.received.items()},
    }


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) else None


def _time(value: Any) -> float | None:
    if isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    return None


def _rows(value: Any, width: int) -> list[list[Any] | tuple[Any, ...]]:
    if not isinstance(value, list | tuple):
        return []
    return [row for row in value if isinstance(row, list | tuple) and len(row) == width]


def _kinds(value: Any) -> dict[str, tuple[int, int]]:
    out: dict[str, tuple[int, int]] = {}
    if not isinstance(value, Mapping):
        return out
    for kind, pair in value.items():
        if isinstance(kind, str) and isinstance(pair, list | tuple) and len(pair) == 2:
            n, b = pair
            if all(isinstance(x, int) and not isinstance(x, bool) and x >= 0 for x in (n, b)):
                out[kind] = (n, b)
    return out


class RemoteNode:
    """A node in another process, read from what the observer last heard of it.

    Whatever a peer published is checked on the way in: a malformed entry is left out,
    never raised on.

    Args:
        node_id: the node's id.
        heard: its properties and display as the observer holds them now (empty once
            it is gone).
        clock_offset: subtracted from the node's times to give the fleet's.
    """

    def __init__(
        self,
        node_id: str,
        heard: Callable[[], Mapping[str, Any]],
        *,
        clock_offset: float = 0.0,
    ) -> None:
        self._node_id = node_id
        self._heard = heard
        self.clock_offset = clock_offset

    @property
    def node_id(self) -> str:
        """The node's id."""
        return self._node_id

    @property
    def properties(self) -> Mapping[str, Any]:
        """Its properties as last heard, without the introspection ones."""
        return {k: v for k, v in self._heard().items() if k not in INTROSPECTION_PROPERTIES}

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """Empty: what the node hears of others stays in its process."""
        return {}

    def sessions(self) -> list[SessionInfo]:
        """The sessions it initiated, as it last published them (times in the fleet's)."""
        out: list[SessionInfo] = []
        for sid, role, prole, members, started, definition in _rows(
            self._heard().get("sessions"), 6
        ):
            at = _time(started)
            if not (_text(sid) and _text(role) and _text(prole) and at is not None):
                continue
            names = (
                frozenset(m for m in members if isinstance(m, str))
                if isinstance(members, list | tuple)
                else frozenset()
            )
            out.append(
                SessionInfo(
                    sid, self._node_id, role, prole, names, frozenset(),
                    at - self.clock_offset, definition,
                )
            )  # fmt: skip
        return out

    def participations(self) -> list[ParticipationInfo]:
        """The participant roles it plays, as it last published them."""
        out: list[ParticipationInfo] = []
        for sid, initiator, role, since in _rows(self._heard().get("roles"), 4):
            at = _time(since)
            if _text(sid) and _text(initiator) and _text(role) and at is not None:
                out.append(ParticipationInfo(sid, initiator, role, at - self.clock_offset))
        return out

    def stats(self) -> NodeStats:
        """Its traffic by kind as it last published it (no drop counters travel)."""
        traffic = self._heard().get("traffic")
        if not isinstance(traffic, Mapping):
            return NodeStats({}, {}, {})
        return NodeStats(_kinds(traffic.get("sent")), _kinds(traffic.get("received")), {})

    def set_participant_factory(self, name: str, factory: Callable[[], Participant] | None) -> None:
        """Nothing: the roles a remote node plays are registered in its own process."""

    def start_interaction(
        self, initiator: Initiator, definition: DefinitionLike, participant_role: str
    ) -> Session:
        """Refused: only the node's own process starts its sessions.

        Raises:
            LocalProtocolError: always.
        """
        raise self._refusal("start a session on it")

    def stop_interaction(self, session: Session | str) -> None:
        """Refused: only the node's own process stops its sessions.

        Raises:
            LocalProtocolError: always.
        """
        raise self._refusal("stop its sessions")

    def view_group(self, definition: DefinitionLike) -> frozenset[str]:
        """Refused: the node's view of the others stays in its process.

        Raises:
            LocalProtocolError: always.
        """
        raise self._refusal("evaluate a group from its point of view")

    def _refusal(self, what: str) -> LocalProtocolError:
        return LocalProtocolError(
            f"node {self._node_id!r} runs in its own process: the dashboard cannot {what}"
        )

    def __repr__(self) -> str:
        return f"<RemoteNode {self._node_id!r}>"
