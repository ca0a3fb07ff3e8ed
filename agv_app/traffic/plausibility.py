"""What an AGV refuses to believe of its peers, and the peers it counts as failed.

Certificates prove who a peer is, not that it tells the truth. A certified node that
lies must not be able to stall the fleet or make it unsafe:

* **Positions that cannot be true.** A peer's position further from the last one
  believed than its top speed covers in the time since (with a slack for delay and
  jitter) is refused: the view keeps the last position believed, and the middleware
  counts the refusal per peer and logs it (``RoleActivator.set_property_check``). A
  peer that truly moved is believed again once enough time has passed.
* **Hull lengths beyond any vehicle's.** A hull length longer than the layout lets any
  AGV publish (:func:`~agv_app.traffic.reach.largest_hull_length`, with a margin) is
  refused the same way: it would pull every AGV near it into its groups.
* **Votes never sent.** Every voter answers a request at once (allow, or defer with a
  reason). A member that has said nothing a ``vote_deadline`` after it was asked is
  counted as failed by the requester: its vote is no longer awaited, and its last
  known circle becomes a stale record, which no request may overlap (as for a crashed
  AGV, docs/traffic.md) until the peer publishes a new hull length. So a silent
  member costs the requests near it a deadline each, never the fleet its progress,
  and no lock is granted into the floor it may still hold.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping
from typing import Any, Final

from agv_app.traffic.lockbook import LockBook, StaleRecord

__all__ = ["JUMP_SLACK_S", "PeerWatch"]

log = logging.getLogger("agv_app.traffic")

JUMP_SLACK_S: Final = 5.0
"""Seconds of driving at top speed allowed beyond the time between two positions: the
updates of a peer may come late and then close together (delay, loss, jitter)."""
_SPEED_FACTOR: Final = 1.5  # a peer's declared top speed may be above our own
_HULL_MARGIN: Final = 1.25
_MAX_PEERS: Final = 4096


class PeerWatch:
    """The property check and the failed-voter record of one AGV.

    Args:
        book: the AGV's lock book (stale records go there).
        view: the node's view of its peers (their last circles).
        top_speed_m_s: the fleet's top speed.
        max_hull_length_m: the longest hull length any AGV of the layout publishes.
        count: counts ``refused_positions``, ``refused_hull_lengths``, ``silent_voters``.
    """

    def __init__(
        self,
        book: LockBook,
        view: Callable[[], Mapping[str, Mapping[str, Any]]],
        *,
        top_speed_m_s: float,
        max_hull_length_m: float,
        count: Callable[[str], None],
    ) -> None:
        self._book = book
        self._view = view
        self._speed = top_speed_m_s * _SPEED_FACTOR
        self._slack_m = top_speed_m_s * JUMP_SLACK_S + 1.0
        self._max_hull = max_hull_length_m * _HULL_MARGIN + 2.0
        self._count = count
        self._believed: dict[str, tuple[float, float, float]] = {}  # node -> x, y, when
        self._told: set[tuple[str, str]] = set()

    def check(self, node_id: str, name: str, value: Any, now: float) -> bool:
        """Whether a peer's new ``name`` may be true (``RoleActivator`` property check)."""
        if name == "position":
            return self._position(node_id, value, now)
        too_long = isinstance(value, int | float) and not 0 <= value <= self._max_hull
        if name == "hull_length" and too_long:
            self._say(node_id, "hull_length", f"{value!r} m is beyond any vehicle's")
            self._count("refused_hull_lengths")
            return False
        return True

    def _position(self, node_id: str, value: Any, now: float) -> bool:
        if not (isinstance(value, tuple | list) and len(value) == 2):
            return True  # not a position the controller reads; the middleware's to judge
        x, y = float(value[0]), float(value[1])
        before = self._believed.get(node_id)
        if before is not None:
            distance = math.hypot(x - before[0], y - before[1])
            if distance > self._speed * max(0.0, now - before[2]) + self._slack_m:
                self._say(
                    node_id,
                    "position",
                    f"({x:g}, {y:g}) is {distance:.0f} m from where it was "
                    f"{now - before[2]:.1f} s before",
                )
                self._count("refused_positions")
                return False
        elif len(self._believed) >= _MAX_PEERS:
            del self._believed[next(iter(self._believed))]
        self._believed[node_id] = (x, y, now)
        return True

    def silent(self, node_id: str) -> None:
        """A member never answered a request in time: count it as failed (its last
        circle a stale record)."""
        self._count("silent_voters")
        self._say(node_id, "vote", "never sent within its deadline: counted as failed")
        props = self._view().get(node_id, {})
        pos, radius = props.get("position"), props.get("hull_length")
        if isinstance(pos, tuple | list) and isinstance(radius, int | float):
            self._book.add_stale(StaleRecord(node_id, float(pos[0]), float(pos[1]), float(radius)))

    def forget(self, node_id: str) -> None:
        """The peer left: what was believed of it goes (a new run starts afresh)."""
        self._believed.pop(node_id, None)

    def _say(self, node_id: str, what: str, why: str) -> None:
        """Log once per peer and kind of lie; the counters keep the rest."""
        key = (node_id, what)
        if key in self._told:
            return
        if len(self._told) >= _MAX_PEERS:
            self._told.clear()
        self._told.add(key)
        log.warning("refused %s of %s: %s", what, node_id, why)
