"""A vehicle cut off from its fleet: it asks for no new floor until it hears it again.

A vehicle on Wi-Fi loses its link (roaming, a dead spot, a failed access point). It
cannot tell a silent fleet from an empty one by itself, but it knows whether it heard
one before. Once it has, and its view empties (every peer silent past the failure
timeout), it is cut off: it withdraws a pending request (with nobody to vote, a
request would lock alone) and asks for nothing more, so it drives on only inside the
floor it has locked and stops there, keeping its locks. The others meanwhile have lost
it too and keep its last circle as a stale record (docs/traffic.md), so nobody locks
into its floor. When it hears the fleet again, it asks again by itself.
"""

from __future__ import annotations

__all__ = ["CutOff"]


class CutOff:
    """Tells whether a vehicle is cut off, from how many peers it hears now."""

    __slots__ = ("_heard", "cut_off", "times_cut_off")

    def __init__(self) -> None:
        self._heard = False
        self.cut_off = False
        """Whether it was cut off at the last look."""
        self.times_cut_off = 0
        """How many times it was cut off."""

    def isolated(self, peers_heard: int) -> bool:
        """Whether a vehicle that hears ``peers_heard`` peers now is cut off."""
        if peers_heard > 0:
            self._heard = True
            self.cut_off = False
            return False
        if self._heard and not self.cut_off:
            self.cut_off = True
            self.times_cut_off += 1
        return self.cut_off
