"""Frames from peers, up to the point where the machine trusts them.

Everything a peer sends passes through the codec once, before any part of the machine
sees it: it decodes a frame and checks it as a whole (size first, then structure, then
the well-known property values: codec.py, values.py). A frame that fails, as bytes
here or as an ``Unusable`` message the transport decoded, is dropped entirely, nothing
of it applied, and counted twice: in the node's counters by reason
(``dropped_malformed``, ``dropped_invalid_property``) and per peer, so a misbehaving
peer can be named. It is logged at most once per peer per
``LOG_INTERVAL`` of the machine's (virtual) clock: a hostile peer must not be able to
flood the log any more than the node.

Network input never raises (STYLE.md §1): whatever is wrong with a frame, it is
dropped and counted, and the node goes on. The per-peer table is bounded
(``MAX_PEERS``, oldest entry evicted), so a peer inventing source ids cannot grow it.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from types import MappingProxyType
from typing import Final

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError
from objectplaces.core.messages import KIND_NAMES, Message
from objectplaces.core.outbox import Outbox

__all__ = ["LOG_BUDGET", "LOG_INTERVAL", "MAX_PEERS", "Intake"]

log = logging.getLogger("objectplaces")

LOG_INTERVAL: Final = 60.0
"""Seconds between two log lines about the same peer's bad frames."""
LOG_BUDGET: Final = 10
"""Log lines about bad frames per ``LOG_INTERVAL`` for all peers together: a peer that
keeps inventing names must not flood the log either."""
MAX_PEERS: Final = 1024
"""Peers whose dropped frames are counted one by one; beyond, the oldest is forgotten."""


class Intake:
    """Decodes the frames one node receives and accounts for the ones it drops.

    Args:
        node_id: this node's id (for log lines).
        max_frame: largest frame accepted, in bytes.
        outbox: where counters go.
    """

    __slots__ = (
        "_by_peer",
        "_logged",
        "_max_frame",
        "_node_id",
        "_outbox",
        "_window",
        "received_by_kind",
    )

    def __init__(self, node_id: str, *, max_frame: int, outbox: Outbox) -> None:
        self._node_id = node_id
        self._max_frame = max_frame
        self._outbox = outbox
        #: kind -> [frames, bytes] received, whatever became of them.
        self.received_by_kind: dict[str, list[int]] = {}
        self._by_peer: dict[str, int] = {}  # frames dropped, per peer
        self._logged: dict[str, float] = {}  # when each peer was last logged about
        self._window = [-LOG_INTERVAL, 0]  # start of the current log window, lines in it

    def decode(self, source: str, data: bytes, now: float) -> Message | None:
        """The message in ``data``, or None when it is refused (counted, maybe logged)."""
        try:
            return codec.decode(data, max_size=self._max_frame)
        except DecodeError as exc:
            self.drop(source, "dropped_malformed", str(exc), now)
            return None

    def admit(self, source: str, message: Message, size: int) -> bool:
        """Tally a decoded frame of ``size`` bytes; whether the machine should act on it
        (not when it claims to come from this node: a transport loop, or a spoofer)."""
        return self._admit(KIND_NAMES[type(message)], source, size)

    def admit_beat(self, source: str, size: int) -> bool:
        """``admit`` for a ``Beat`` (whose kind is known without a lookup)."""
        # ``_admit`` written out: a beat is the most frequent frame, one per listener
        # per beat interval.
        tally = self.received_by_kind.get("beat")
        if tally is None:
            tally = self.received_by_kind["beat"] = [0, 0]
        tally[0] += 1
        tally[1] += size
        if source == self._node_id:
            self._outbox.count("dropped_own")
            return False
        return True

    def _admit(self, kind: str, source: str, size: int) -> bool:
        """``admit`` for a frame whose kind name is known."""
        tally = self.received_by_kind.get(kind)
        if tally is None:  # not setdefault: its default list would be made for every frame
            tally = self.received_by_kind[kind] = [0, 0]
        tally[0] += 1
        tally[1] += size
        if source == self._node_id:
            self._outbox.count("dropped_own")
            return False
        return True

    def drop(self, source: str, reason: str, detail: str, now: float) -> None:
        """Count one frame from ``source`` dropped for ``reason``; log it unless logged lately."""
        self._outbox.count(reason)
        by_peer = self._by_peer
        by_peer[source] = by_peer.pop(source, 0) + 1  # re-inserted: newest last
        if len(by_peer) > MAX_PEERS:
            del by_peer[next(iter(by_peer))]
        last = self._logged.get(source)
        if last is not None and now - last < LOG_INTERVAL:
            return
        if now - self._window[0] >= LOG_INTERVAL:
            self._window = [now, 0]
        self._window[1] += 1
        if self._window[1] <= LOG_BUDGET:
            self._logged.pop(source, None)
            self._logged[source] = now
            if len(self._logged) > MAX_PEERS:
                del self._logged[next(iter(self._logged))]
            log.warning(
                "node %s: dropped a frame from %s (%s): %s (%d so far; more within %gs "
                "are counted, not logged)",
                self._node_id,
                source,
                reason,
                detail,
                by_peer[source],
                LOG_INTERVAL,
            )

    @property
    def dropped_by_peer(self) -> Mapping[str, int]:
        """Frames dropped per peer (read-only; the ``MAX_PEERS`` most recent peers)."""
        return MappingProxyType(self._by_peer)

    def footprint(self) -> dict[str, int]:
        """Sizes of the per-peer tables (each at most ``MAX_PEERS``)."""
        return {"dropped_peers": len(self._by_peer), "logged_peers": len(self._logged)}
