"""Who is in the fleet, from Zenoh's liveliness tokens (asyncio).

A token also carries its node's fleet tag (``FleetKeys``): a node whose tag is not ours
is of another fleet (another layout, say). It is no member; the transport drops what it
sends (``foreign``), and ``refusals`` says why, naming both tags, once per node.

Every node holds the token ``alive/<node>/<incarnation>`` while its session lives and
hears every token of its fleet. A token that appears is a node that joined (a newer
incarnation: a restart, and the earlier run leaves every group); a token that goes and
is not back within the grace (``ZenohOptions.token_grace``) is a node that is gone: it
left, its process died, or its links fell silent past the lease. Either way it leaves
every group then, with no heartbeat of ours. Every ``RECONCILE_EVERY`` seconds the node
asks for every token up, so a token report lost while links churn is made good.

The decisions are ``AliveTable``'s; this module declares, queries and keeps the timers.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import Any

from objectplaces.transport.base import NodeDriver
from objectplaces.transport.zenoh_alive import TOKEN_GRACE, AliveTable, Change
from objectplaces.transport.zenoh_inbox import ZenohInbox
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.transport.zenoh_lib import zenoh

__all__ = ["QUERY_TIMEOUT", "RECONCILE_EVERY", "Membership"]

log = logging.getLogger("objectplaces.zenoh")

_MAX_FOREIGN = 1024
"""Nodes of another fleet tag remembered at most (then forgotten, and told again)."""

RECONCILE_EVERY = 3.0
"""Seconds between two liveliness queries of every token up: a token report lost while
links churn (many processes starting on a loaded machine) is made good by the next."""
QUERY_TIMEOUT = 2.0
"""Seconds a Zenoh query (of tokens, of properties) waits for its answers."""


class Membership:
    """The nodes of one node's fleet whose token is up, and what their comings and
    goings mean to the node machine.

    Args:
        keys: the fleet's keys, as this node uses them.
        counters: the transport's counters (``tokens_gone``, ``dropped_query_failed``).
        on_new_run: called with a node that appeared or restarted (the transport asks it
            for its properties).
        grace: seconds a node whose token went stays a member unless it is back.
    """

    def __init__(
        self,
        keys: FleetKeys,
        counters: dict[str, int],
        on_new_run: Callable[[str], None],
        *,
        grace: float = TOKEN_GRACE,
    ) -> None:
        self.keys = keys
        self._counters = counters
        self._on_new_run = on_new_run
        self._table = AliveTable(keys.node, grace)
        self._driver: NodeDriver | None = None
        self._session: zenoh.Session | None = None
        self._inbox: ZenohInbox | None = None
        self._queries = 0
        self._reconcile_timer: asyncio.TimerHandle | None = None
        self._changed = asyncio.Event()
        self._closed = False
        self.foreign: set[str] = set()
        """Nodes whose token has another fleet tag: what they send is dropped."""
        self.refusals: dict[str, str] = {}
        """Why each of ``foreign`` is no member."""
        self._incarnation: int | None = None
        self._twins: dict[int, float] = {}  # another run's token of our own id: since when

    def attach(self, driver: NodeDriver) -> None:
        """Connect the driver of the node machine that hears of arrivals and departures."""
        self._driver = driver

    def declare(self, session: zenoh.Session, inbox: ZenohInbox, incarnation: int) -> list[Any]:
        """Hear every token of the fleet (with history), declare ours, start the
        periodic query; returns what was declared (undeclared with the session).
        Again on a new session (``suspend`` first): the tokens already known stay."""
        self.suspend()
        self._session, self._inbox = session, inbox
        self._incarnation = incarnation
        liveliness = session.liveliness()
        declared = [
            liveliness.declare_subscriber(
                self.keys.alive_all(), inbox.alive_callback(self.keys), history=True
            ),
            liveliness.declare_token(self.keys.alive(incarnation)),
        ]
        self._reconcile_timer = asyncio.get_running_loop().call_later(
            RECONCILE_EVERY, self._reconcile
        )
        return declared

    def suspend(self) -> None:
        """Stop the periodic query until ``declare`` (the session is being replaced)."""
        self._session = None
        if self._reconcile_timer is not None:
            self._reconcile_timer.cancel()
            self._reconcile_timer = None

    def forget(self, node: str) -> None:
        """``node`` may no longer take part (its certificate was revoked): it leaves
        every group now, whatever its token says."""
        self._table.forget(node)
        if self._driver is not None:
            self._driver.peer_restarted(node)
        self._signal()

    def close(self) -> None:
        """Stop the periodic query (a grace that runs out later changes nothing); signal
        whoever waits for a change."""
        self._closed = True
        if self._reconcile_timer is not None:
            self._reconcile_timer.cancel()
        self._signal()

    # ------------------------------------------------------------------ looking

    def peers(self) -> list[str]:
        """Nodes whose token is up (or went less than the grace ago), sorted."""
        return self._table.nodes()

    async def changed(self) -> None:
        """Wait until a node appears or goes (or membership closes)."""
        await self._changed.wait()

    # ------------------------------------------------------------------ reports

    def twin_up_for(self) -> float | None:
        """Seconds a token of our own id but of an earlier run has been up (None: none).

        A run that crashed and was started again sees its old token until the lease
        runs out; one that stays up longer is another process with this id, which was
        there first (the later run gives way: an earlier one sees no twin)."""
        if not self._twins:
            return None
        return asyncio.get_running_loop().time() - min(self._twins.values())

    def token_up(self, node: str, incarnation: int, tag: str = "") -> None:
        """Zenoh reported a token of ``node``'s run ``incarnation`` with fleet ``tag``."""
        if node == self.keys.node:
            ours = self._incarnation
            if ours is not None and incarnation < ours:
                self._twins.setdefault(incarnation, asyncio.get_running_loop().time())
            return
        if self._same_fleet(node, tag):
            self._new_run(node, self._table.token_up(node, incarnation))

    def answered(self, node: str, incarnation: int, tag: str, query: int) -> None:
        """Liveliness query number ``query`` found this token up."""
        if node == self.keys.node:
            return  # a twin of ours is seen by its own report (``token_up``)
        if self._same_fleet(node, tag):
            self._new_run(node, self._table.answered(node, incarnation, query))

    def token_down(self, node: str, incarnation: int) -> None:
        """Zenoh reported that the token of ``node``'s run ``incarnation`` went."""
        if node == self.keys.node:
            self._twins.pop(incarnation, None)
            return
        if node in self.foreign:
            return
        loop = asyncio.get_running_loop()
        change = self._table.token_down(node, incarnation, loop.time(), self._queries)
        if change is Change.MISSING:
            loop.call_later(self._table.grace, self._expire)

    # ------------------------------------------------------------------ inside

    def _same_fleet(self, node: str, tag: str) -> bool:
        """Whether ``node``'s token has our tag; if not, it is foreign from now on."""
        ours = self.keys.tag
        if tag == ours:
            self.foreign.discard(node)  # a run of it with our tag
            self.refusals.pop(node, None)
            return True
        if node not in self.foreign:
            if len(self.foreign) >= _MAX_FOREIGN:
                self.foreign.clear()
                self.refusals.clear()
            self.foreign.add(node)
            reason = f"another fleet: {node} runs {tag!r}, {self.keys.node} runs {ours!r}"
            self.refusals[node] = reason
            self._count("refused_tag")
            log.warning("node %s: %s", self.keys.node, reason)
        return False

    def _new_run(self, node: str, change: Change) -> None:
        if change is Change.RESTARTED and self._driver is not None:
            self._driver.peer_restarted(node)
        if change is not Change.NOTHING:
            self._on_new_run(node)
            self._signal()

    def _expire(self) -> None:
        """The runs missing for the whole grace are gone: whether they left or died,
        they leave every group now."""
        if self._closed:
            return
        gone = self._table.expire(asyncio.get_running_loop().time())
        if self._driver is not None:
            for node in gone:
                self._driver.peer_restarted(node)
        if gone:
            self._count("tokens_gone", len(gone))
            self._signal()

    def _reconcile(self) -> None:
        """Ask for every token up now (an answer counts as a token report, but for a
        node reported gone after the query left), then again later."""
        session, inbox = self._session, self._inbox
        if self._closed or session is None or inbox is None:
            return
        self._queries += 1
        on_reply = inbox.alive_reply_callback(self.keys, self._queries)
        try:
            session.liveliness().get(self.keys.alive_all(), on_reply, timeout=QUERY_TIMEOUT)
        except zenoh.ZError:
            self._count("dropped_query_failed")
        loop = asyncio.get_running_loop()
        self._reconcile_timer = loop.call_later(RECONCILE_EVERY, self._reconcile)

    def _signal(self) -> None:
        self._changed.set()
        self._changed = asyncio.Event()

    def _count(self, name: str, amount: int = 1) -> None:
        self._counters[name] = self._counters.get(name, 0) + amount
