"""Which runs of which nodes hold a liveliness token now (sans-I/O).

Zenoh reports a token's appearance (put) and disappearance (delete); a node that
restarts declares a token of a newer incarnation, and the two reports of its old and
new runs may arrive in either order. A run reported gone may be reported up again
(peers withdraw and redeclare tokens as the routes between them change).
``AliveTable`` turns them into what the node machine needs to know: a node appeared,
came back as a new run, or is gone.
"""

from __future__ import annotations

from enum import Enum

__all__ = ["AliveTable", "Change"]


class Change(Enum):
    """What one liveliness report means."""

    NOTHING = "nothing"
    APPEARED = "appeared"
    RESTARTED = "restarted"
    GONE = "gone"


class AliveTable:
    """The newest incarnation of every node whose token is up."""

    __slots__ = ("_alive", "_me")

    def __init__(self, me: str) -> None:
        self._me = me
        self._alive: dict[str, int] = {}

    def token_up(self, node: str, incarnation: int) -> Change:
        """A token of ``node``'s run ``incarnation`` appeared."""
        if node == self._me:
            return Change.NOTHING
        known = self._alive.get(node)
        if known is not None and known >= incarnation:
            return Change.NOTHING
        self._alive[node] = incarnation
        return Change.APPEARED if known is None else Change.RESTARTED

    def token_down(self, node: str, incarnation: int) -> Change:
        """A token of ``node``'s run ``incarnation`` went away (it left, or was lost)."""
        if self._alive.get(node) != incarnation:
            return Change.NOTHING  # an older run's token, or one never seen
        del self._alive[node]
        return Change.GONE

    def nodes(self) -> list[str]:
        """Nodes alive now, sorted."""
        return sorted(self._alive)

    def __contains__(self, node: object) -> bool:
        return node in self._alive

    def __len__(self) -> int:
        return len(self._alive)
