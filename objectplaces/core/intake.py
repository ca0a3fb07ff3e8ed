"""Frames from peers, up to the point where the machine trusts them.

Everything a peer sends passes through here once, before any part of the machine
sees it: bytes are decoded (size first, then structure: codec.py), every frame is
tallied by kind for ``stats()``, and a frame that claims to come from this node
itself is dropped (a transport loop or a spoofing peer; never something to act on).

Network input never raises (STYLE.md §1): whatever is wrong with a frame, it is
dropped and counted, and the node goes on.
"""

from __future__ import annotations

import logging

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError
from objectplaces.core.messages import Message
from objectplaces.core.outbox import Outbox

__all__ = ["Intake"]

log = logging.getLogger("objectplaces")


class Intake:
    """Decodes, tallies and screens the frames one node receives.

    Args:
        node_id: this node's id.
        max_frame: largest frame accepted, in bytes.
        outbox: where counters go.
    """

    __slots__ = ("_max_frame", "_node_id", "_outbox")

    def __init__(self, node_id: str, *, max_frame: int, outbox: Outbox) -> None:
        self._node_id = node_id
        self._max_frame = max_frame
        self._outbox = outbox

    def decode(self, source: str, data: bytes) -> Message | None:
        """The message in ``data``, or None when it does not decode (counted, logged)."""
        try:
            return codec.decode(data, max_size=self._max_frame)
        except DecodeError as exc:
            self._outbox.count("dropped_malformed")
            log.warning("node %s: dropped a frame from %s: %s", self._node_id, source, exc)
            return None
