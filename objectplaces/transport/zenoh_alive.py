"""Which runs of which nodes hold a liveliness token now (sans-I/O).

Zenoh reports a token's appearance (put) and disappearance (delete); a node that
restarts declares a token of a newer incarnation, and the two reports of its old and
new runs may arrive in either order. A run reported gone may be reported up again:
peers withdraw and redeclare tokens as the routes between them change. So a run
reported gone is only *missing* for a grace period (``TOKEN_GRACE``); if its token is
back within it, nothing happened, and only a run still missing after it is gone.
``AliveTable`` turns the reports into what the node machine needs to know: a node
appeared, came back as a new run, or is gone.

The periodic liveliness query (``ZenohTransport``) answers with the tokens up when it
ran; an answer to a query sent before a run was reported missing is old news and
changes nothing.
"""

from __future__ import annotations

from enum import Enum

__all__ = ["TOKEN_GRACE", "AliveTable", "Change"]

TOKEN_GRACE = 1.0
"""Seconds a run reported gone stays a member before it leaves its groups: a token
withdrawn and redeclared as routes change comes back well within it, and a node
whose process died leaves its groups that much later."""


class Change(Enum):
    """What one liveliness report means."""

    NOTHING = "nothing"
    APPEARED = "appeared"
    RESTARTED = "restarted"
    MISSING = "missing"
    GONE = "gone"


class AliveTable:
    """The newest incarnation of every node whose token is up or missing for less than
    the grace.

    Args:
        me: this node's id (its own token is no peer).
        grace: seconds a missing run stays before it is gone (0: gone at once).
    """

    __slots__ = ("_alive", "_gone_after_query", "_me", "_missing", "grace")

    def __init__(self, me: str, grace: float = TOKEN_GRACE) -> None:
        if not grace >= 0:
            raise ValueError(f"grace must be >= 0 seconds, got {grace!r}")
        self._me = me
        self.grace = grace
        self._alive: dict[str, int] = {}
        self._missing: dict[str, float] = {}  # node -> when it is gone unless back
        self._gone_after_query: dict[str, int] = {}  # node -> queries sent when it went

    def token_up(self, node: str, incarnation: int) -> Change:
        """A token of ``node``'s run ``incarnation`` appeared (or is back)."""
        if node == self._me:
            return Change.NOTHING
        known = self._alive.get(node)
        if known is not None and known >= incarnation:
            if known == incarnation:
                self._missing.pop(node, None)  # back within the grace: it never left
            return Change.NOTHING
        self._missing.pop(node, None)  # a newer run: the old one ends now
        self._alive[node] = incarnation
        return Change.APPEARED if known is None else Change.RESTARTED

    def answered(self, node: str, incarnation: int, query: int) -> Change:
        """The liveliness query numbered ``query`` found this token up: ``token_up``,
        unless the query went out before the run was reported gone."""
        if query <= self._gone_after_query.get(node, 0):
            return Change.NOTHING
        return self.token_up(node, incarnation)

    def token_down(self, node: str, incarnation: int, now: float, queries_sent: int) -> Change:
        """A token of ``node``'s run ``incarnation`` went away (it left, or was lost) at
        ``now``, after ``queries_sent`` liveliness queries: the run is missing, and gone
        at ``now + grace`` unless its token is back first (``expire``)."""
        if self._alive.get(node) != incarnation or node in self._missing:
            return Change.NOTHING  # an older run's token, one never seen, or missing already
        self._gone_after_query[node] = queries_sent
        self._missing[node] = now + self.grace
        return Change.MISSING

    def expire(self, now: float) -> list[str]:
        """The runs missing for the whole grace by ``now``: gone (``Change.GONE``), out
        of the table; sorted by node."""
        gone = sorted(n for n, due in self._missing.items() if due <= now)
        for node in gone:
            del self._missing[node]
            del self._alive[node]
        return gone

    def forget(self, node: str) -> bool:
        """Drop ``node`` whatever its token does; True if it was in the table."""
        self._missing.pop(node, None)
        self._gone_after_query.pop(node, None)
        return self._alive.pop(node, None) is not None

    def next_expiry(self) -> float | None:
        """When the first missing run is gone unless back (None: none is missing)."""
        return min(self._missing.values(), default=None)

    def nodes(self) -> list[str]:
        """Nodes alive now (a missing run still counts), sorted."""
        return sorted(self._alive)

    def missing(self) -> list[str]:
        """Nodes whose token went less than the grace ago and is not back, sorted."""
        return sorted(self._missing)

    def __contains__(self, node: object) -> bool:
        return node in self._alive

    def __len__(self) -> int:
        return len(self._alive)
