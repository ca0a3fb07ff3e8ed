"""What a receiver grants its peers at rest (docs/protocol.md §2, "A node at rest").

A peer at rest beats every ``rest`` seconds instead of every ``beat_interval``, and says
so in its beats; the receiver then counts it failed only after ``failure_timeout``
scaled by ``rest / beat_interval``, with ``rest`` capped at its own
``rest_beat_interval``. Only the beats that announce the rest say so; the plain beats
that follow keep the grant. It ends with the peer's next change (a delta) or a beat
that says its rest ended (0). The sender's side is
:mod:`objectplaces.core.liveness`.
"""

from __future__ import annotations

from objectplaces.core.config import NodeConfig

__all__ = ["RestGrants"]


class RestGrants:
    """How much longer than the failure timeout each peer at rest may stay silent.

    Args:
        config: the receiver's tunables (failure timeout, beat and rest intervals).
    """

    __slots__ = ("_extra", "_terms")

    def __init__(self, config: NodeConfig) -> None:
        self._extra: dict[str, float] = {}
        timeout, beat, lease = (
            config.effective_failure_timeout,
            config.beat_interval,
            config.longest_lease,
        )
        # None: this node allows no rest (or detects no failures): it grants nothing.
        self._terms = (
            None
            if timeout is None or beat is None or lease is None or lease <= timeout
            else (timeout, beat, lease)
        )

    def __len__(self) -> int:
        return len(self._extra)

    def beat(self, node: str, rest: float) -> None:
        """A beat of ``node`` that says it is at rest, beating every ``rest`` seconds
        (grant it the longer wait), or that its rest ended (0: the usual wait again)."""
        terms = self._terms
        if not rest or terms is None:
            self._extra.pop(node, None)
            return
        timeout, beat, longest = terms
        extra = min(timeout * rest / beat, longest) - timeout
        if extra > 0:
            self._extra[node] = extra
        else:
            self._extra.pop(node, None)

    def ended(self, node: str) -> None:
        """``node`` is no longer at rest (or no longer known): the usual wait again."""
        self._extra.pop(node, None)

    def extra(self, node: str) -> float:
        """Seconds beyond the failure timeout ``node`` may be silent (0 if not at rest)."""
        return self._extra.get(node, 0.0)
