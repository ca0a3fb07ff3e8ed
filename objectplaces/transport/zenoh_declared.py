"""What one node declares on its Zenoh session, kept so that a new session declares it
all again (a peer opens its session anew when the fleet's roster changes).

A node hears its inbox, the broadcasts and the cells of its subscription, holds its
liveliness token, and keeps a queryable in every cell it publishes in. ``Subscribe``
declares one subscriber per row of interest cells, or the one wildcard of full
dissemination: Zenoh routes each update only to the nodes that hear it. A node that
starts hearing a cell asks the queryables there (``who/<cell>/*``), and a node that sees
a new token asks that node; the asker's subscription travels in the query, so nobody
answers out of scope. While there is no session, what the node asks to declare is
only remembered: the next session declares it.
"""

from __future__ import annotations

import asyncio
from typing import Any, Final

import msgpack

from objectplaces.transport.routing import Cell
from objectplaces.transport.zenoh_inbox import ZenohInbox, direct
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.transport.zenoh_lib import zenoh
from objectplaces.transport.zenoh_membership import QUERY_TIMEOUT, Membership

__all__ = ["ASK_AGAIN_AFTER", "Declared"]

ASK_AGAIN_AFTER: Final = (0.3, 1.5)
"""Seconds after which an ask is repeated: an asked node's queryable, just moved to the
cell we ask, may not have reached us yet (nor our subscription it), and a node without
a heartbeat would otherwise stay unheard. Repeated answers are harmless snapshots."""


class Declared:
    """One node's declarations: on its session while it has one, remembered meanwhile.

    Args:
        keys: the fleet's keys, as this node uses them.
        inbox: where what the subscribers and queryables hear goes.
        membership: the liveliness side (its subscriber and our token).
        counters: the transport's counters (``dropped_query_failed``).
        incarnation: this run's number, in our token.
    """

    def __init__(
        self,
        keys: FleetKeys,
        inbox: ZenohInbox,
        membership: Membership,
        counters: dict[str, int],
        *,
        incarnation: int,
    ) -> None:
        self.keys = keys
        self._inbox = inbox
        self._membership = membership
        self._counters = counters
        self._incarnation = incarnation
        self.session: zenoh.Session | None = None
        self._held: list[Any] = []  # held: what is dropped may be undeclared
        self._row_subs: dict[int, Any] = {}  # one subscriber per row of our cells
        self._full_sub: Any = None
        self._queryables: dict[Cell | None, Any] = {}  # one per home cell (None: no cell)
        self.subscribed = False
        self.subscription: frozenset[Cell] | None = None
        self.cells: frozenset[Cell] = frozenset()  # the cells we hear (none when full)
        self.home: tuple[Cell, ...] = ()  # the cells we publish in (none before a position)

    def declare(self, session: zenoh.Session) -> None:
        """Declare everything on ``session``: inbox, broadcasts, queryables, token, and
        the cells subscribed to (asking them again)."""
        self.session = session
        keys, inbox = self.keys, self._inbox
        self._held = [
            inbox.declare_data(session, keys.inbox(), keys, directed=True),
            inbox.declare_data(session, keys.broadcasts(), keys),
            *self._membership.declare(session, inbox, self._incarnation),
        ]
        for cell in self.home or (None,):
            self._queryables[cell] = session.declare_queryable(
                keys.who(cell), inbox.query_callback()
            )
        if self.subscribed:
            wanted, self.subscribed = self.subscription, False
            self.cells, self._row_subs, self._full_sub = frozenset(), {}, None
            self.subscribe(wanted)

    def drop(self) -> None:
        """The session is going: its declarations go with it; remember them."""
        self.session = None
        self._membership.suspend()
        self._inbox.forget_subscribers()
        self._held, self._queryables = [], {}
        self._row_subs, self._full_sub = {}, None

    def publishing_in(self, home: tuple[Cell, ...]) -> None:
        """Keep a queryable in every cell we publish in, so that askers there find us."""
        if home == self.home:
            return
        self.home = home
        session = self.session
        if session is None:
            return
        wanted: tuple[Cell | None, ...] = home or (None,)
        for cell in wanted:  # the new ones first: an asker never finds a gap
            if cell not in self._queryables:
                self._queryables[cell] = session.declare_queryable(
                    self.keys.who(cell), self._inbox.query_callback()
                )
        for cell in [c for c in self._queryables if c not in wanted]:
            self._queryables.pop(cell).undeclare()

    def subscribe(self, cells: frozenset[Cell] | None) -> None:
        """Hear ``cells`` (None: every cell), and ask the nodes of the new ones."""
        session, keys, inbox = self.session, self.keys, self._inbox
        if session is None:
            self.subscribed, self.subscription = True, cells
            return
        first = not self.subscribed
        was_full = self.subscribed and self.subscription is None
        self.subscribed = True
        self.subscription = cells
        asks: list[str] = []
        had = self.cells
        self.cells = frozenset() if cells is None else cells
        if cells is None:
            for sub in self._row_subs.values():
                sub.undeclare()
            self._row_subs.clear()
            if self._full_sub is None:
                self._full_sub = inbox.declare_data(session, keys.all_props(), keys)
            if not was_full:
                asks.append(keys.who_all())
        else:
            if self._full_sub is not None:
                self._full_sub.undeclare()
                self._full_sub = None
            # A subscriber per row of cells, not per cell: every subscriber of a session
            # costs on every sample it receives (a receiver with an 8 by 8 square of cell
            # subscribers spent 161 µs of its receiving threads' CPU per sample, 86 with
            # one subscriber). Updates from the row's other cells are dropped on the
            # loop (``ZenohTransport._on_items``).
            rows = {cy for _, cy in cells}
            for row in [r for r in self._row_subs if r not in rows]:
                self._row_subs.pop(row).undeclare()
            for row in sorted(rows - self._row_subs.keys()):
                self._row_subs[row] = inbox.declare_data(session, keys.row_subscription(row), keys)
            asks += [keys.who_in(cell) for cell in sorted(cells - had)]
            if first:
                asks.append(keys.who_in(None))
        for selector in asks:
            self.ask(selector)

    def ask(self, selector: str) -> None:
        """Ask the queryables matching ``selector`` for their properties, now and again
        a little later (``ASK_AGAIN_AFTER``)."""
        self._ask_once(selector)
        loop = asyncio.get_running_loop()
        for delay in ASK_AGAIN_AFTER:
            loop.call_later(delay, self._ask_once, selector)

    def ask_new_run(self, node: str) -> None:
        """A node appeared or restarted: ask it for its properties (once we hear cells)."""
        if self.subscribed:
            self.ask(self.keys.who_is(node))

    def should_answer(self, cells: frozenset[Cell] | None) -> bool:
        """Whether an asker hearing ``cells`` (None: everything) should hear us."""
        return cells is None or not self.home or not cells.isdisjoint(self.home)

    def _ask_once(self, selector: str) -> None:
        session = self.session
        if session is None:
            return
        cells = None if self.subscription is None else sorted(self.subscription)
        payload = msgpack.packb([self.keys.node, cells])
        try:
            session.get(selector, _IGNORE_REPLY, payload=payload, timeout=QUERY_TIMEOUT)
        except zenoh.ZError:
            self._counters["dropped_query_failed"] = (
                self._counters.get("dropped_query_failed", 0) + 1
            )


def _ignore_reply(_reply: zenoh.Reply) -> None:
    """Answers travel on the asker's inbox key, not as replies."""


_IGNORE_REPLY = direct(_ignore_reply)
