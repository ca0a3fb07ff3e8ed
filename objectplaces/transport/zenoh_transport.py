"""The Zenoh transport: one node's session, its keys, and the frames it moves (asyncio).

Outputs of the node machine become puts on the fleet's keys (``zenoh_keys``): ``Publish``
on the cell keys, ``Broadcast`` on the node's broadcast key, ``Send`` on the target's
inbox key. ``Subscribe`` declares one subscriber per row of interest cells, or the one
wildcard of full dissemination: Zenoh routes each update only to the nodes that hear it.

Membership is Zenoh's liveliness: every node holds a token while its session lives; a
node whose token goes (it left, its process died, its links lapsed past the lease) and
is not back within the grace (``ZenohOptions.token_grace``; a token redeclared as routes
change is) is gone, and the machine lets it leave every group then, with no heartbeat of
ours.

A node that starts hearing a cell asks the queryables there (``who/<cell>/*``), and a
node that sees a new token asks that node; an asked node whose properties the asker
should hear sends it a snapshot on its inbox key. The asker's subscription travels in
the query, so nobody answers out of scope.

With a certified identity, links are mutual TLS and the fleet's roster (``zenoh_roster``)
is looked at every ``ROSTER_CHECK`` seconds: what a revoked id sends is dropped
(``dropped_revoked``) and it leaves every group at once. A peer also applies the
fleet's access control to its own links (``zenoh_acl``); when the roster changes it
opens its session anew with the new rules, which closes the revoked member's links
(``reopened`` counts it; the others link again within a second or two).

Zenoh calls back on its own threads, which only queue each sample (``ZenohInbox``); on
the event loop the frames that came together go to the driver in one call. The node
machine's own intake decodes them: a malformed payload is counted, never stops the node.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from typing import Any, Protocol

import msgpack
import zenoh

from objectplaces.core.events import Broadcast, Output, Publish, Send, Subscribe
from objectplaces.security.identity import Identity
from objectplaces.transport.base import RawNodeDriver
from objectplaces.transport.routing import Cell
from objectplaces.transport.zenoh_acl import Roster, fleet_access_control
from objectplaces.transport.zenoh_config import (
    Credentials,
    CredentialsFile,
    ZenohOptions,
    ZenohSecurity,
    derive_credentials,
    zenoh_config,
)
from objectplaces.transport.zenoh_inbox import Item, ZenohInbox, direct
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.transport.zenoh_membership import QUERY_TIMEOUT, Membership
from objectplaces.transport.zenoh_publishers import PublisherCache
from objectplaces.transport.zenoh_roster import ROSTER_CHECK, RosterWatch

__all__ = ["FrameDriver", "ZenohTransport"]

log = logging.getLogger("objectplaces.zenoh")

_ASK_AGAIN_AFTER = (0.3, 1.5)
"""Seconds after which an ask is repeated: an asked node's queryable, just moved to the
cell we ask, may not have reached us yet (nor our subscription it), and a node without
a heartbeat would otherwise stay unheard. Repeated answers are harmless snapshots."""


class FrameDriver(RawNodeDriver, Protocol):
    """A driver that also takes the frames that arrived together, in one call."""

    def deliver_frames(self, frames: list[tuple[str, bytes]]) -> int:
        """Hand the node these frames in order; returns how many failed."""
        ...


class ZenohTransport:
    """One node's Zenoh session.

    Args:
        node_id: this node's id.
        options: mode, endpoints, fleet, lease.
        incarnation: distinguishes this run of the node from earlier ones (larger is newer).
        tls: the node's certified identity: mutual TLS links, the roster watched.
        secret: user/password authentication derived from it (plain links on loopback;
            with ``tls``, a second factor).

    Raises:
        CredentialError: with ``tls``, the PKI folder holds no readable ``members.json``.
    """

    def __init__(
        self,
        node_id: str,
        *,
        options: ZenohOptions,
        incarnation: int,
        tls: Identity | None = None,
        secret: bytes | None = None,
    ) -> None:
        self.node_id = node_id
        self.options = options
        self.incarnation = incarnation
        self.keys = FleetKeys(options.fleet, node_id)
        self.counters: dict[str, int] = {}
        self._tls = tls
        self._credentials: Credentials | None = (
            derive_credentials(secret, options.fleet) if secret is not None else None
        )
        self._roster = RosterWatch(tls) if tls is not None else None
        self._revoked: frozenset[str] = frozenset()
        self._driver: FrameDriver | None = None
        self._session: zenoh.Session | None = None
        self._publishers: PublisherCache | None = None
        self._file: CredentialsFile | None = None
        self._inbox: ZenohInbox | None = None
        self._watcher: asyncio.Task[None] | None = None
        self._reopening = False
        self.membership = Membership(
            self.keys, self.counters, self._ask_new_run, grace=options.token_grace
        )
        self._declared: list[Any] = []  # held: what is dropped may be undeclared
        self._row_subs: dict[int, Any] = {}  # one subscriber per row of our cells
        self._full_sub: Any = None
        self._subscription: frozenset[Cell] | None = None
        self._cells: frozenset[Cell] = frozenset()  # the cells we hear (none when full)
        self._subscribed = False
        self._home: tuple[Cell, ...] = ()  # the cells we publish in (none before a position)
        self._queryables: dict[Cell | None, Any] = {}  # one per home cell (None: no cell)
        self.closed = False
        if self._roster is not None:
            self._revoked = frozenset(self._roster.roster.revoked)

    # ------------------------------------------------------------------ lifecycle

    def attach(self, driver: FrameDriver) -> None:
        """Connect whoever drives the node machine this transport carries."""
        self._driver = driver
        self.membership.attach(driver)

    @property
    def address(self) -> str:
        """The endpoints this node listens on (comma separated; "" for a client)."""
        return ",".join(self.options.listen) if self.options.mode != "client" else ""

    @property
    def revoked(self) -> frozenset[str]:
        """Ids whose certificates are all revoked, as last read (empty without TLS)."""
        return self._revoked

    def _security(self) -> ZenohSecurity:
        """How the session protects its links now: a peer with TLS applies the fleet's
        access control to its own links (a client's only link is to a router)."""
        usrpwd = None
        if self._credentials is not None:
            assert self._file is not None
            usrpwd = (self._credentials, self._file.path)
        acl = None
        if self._roster is not None and self.options.mode == "peer":
            acl = fleet_access_control(self.options.fleet, self._roster.roster)
        return ZenohSecurity(
            tls=self._tls,
            verify_name=self.options.mode == "client",  # peers' certificates name no host
            usrpwd=usrpwd,
            access_control=acl,
        )

    async def open(self) -> None:
        """Open the session and declare what every node hears: its inbox, the broadcasts,
        the liveliness tokens, its queryable; then its own token.

        Raises:
            OSError: Zenoh refused the configuration or could not listen.
        """
        loop = asyncio.get_running_loop()
        self._inbox = ZenohInbox(
            loop,
            self._on_items,
            self.counters,
            max_frame=self.options.max_frame,
            poll_interval=self.options.poll_interval,
        )
        if self._credentials is not None:
            self._file = CredentialsFile(self._credentials)
        try:
            self._session = await self._open_session()
        except OSError:
            if self._file is not None:
                self._file.remove()
            raise
        self._declare(self._session)
        if self._roster is not None:
            self._watcher = loop.create_task(self._watch_roster())

    async def _open_session(self) -> zenoh.Session:
        config = zenoh_config(self.options, self._security())
        try:
            return await asyncio.to_thread(zenoh.open, config)
        except zenoh.ZError as exc:
            raise OSError(f"zenoh: {exc}") from exc

    def _declare(self, session: zenoh.Session) -> None:
        """Declare on ``session`` what this node hears and holds: its inbox, the
        broadcasts, its queryables, its token, and the cells it subscribed to."""
        keys, inbox = self.keys, self._inbox
        assert inbox is not None
        self._publishers = PublisherCache(session)
        self._declared = [
            inbox.declare_data(session, keys.inbox(), keys, directed=True),
            inbox.declare_data(session, keys.broadcasts(), keys),
            *self.membership.declare(session, inbox, self.incarnation),
        ]
        for cell in self._home or (None,):
            self._queryables[cell] = session.declare_queryable(
                keys.who(cell), inbox.query_callback()
            )
        if self._subscribed:  # a session opened anew: subscribe and ask again
            wanted, self._subscribed = self._subscription, False
            self._cells, self._row_subs, self._full_sub = frozenset(), {}, None
            self._subscribe(wanted)

    async def close(self) -> None:
        """Withdraw our token and close the session (what was put is flushed first;
        a close that times out in Zenoh is logged, never raised)."""
        if self.closed:
            return
        self.closed = True
        self.membership.close()
        watcher = self._watcher
        if watcher is not None:
            if not self._reopening:  # a session being opened is let finish, then closed
                watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watcher
        if self._inbox is not None:
            self._inbox.close()
        session, self._session = self._session, None
        if session is not None:
            await self._close_session(session)
        if self._file is not None:
            self._file.remove()

    async def _close_session(self, session: zenoh.Session) -> None:
        try:
            await asyncio.to_thread(session.close)
        except zenoh.ZError as exc:
            # Zenoh gave up flushing (a machine too loaded to finish in time): the
            # session is dropped all the same, and peers see our token go.
            log.warning("node %s: closing the Zenoh session: %s", self.node_id, exc)

    # ------------------------------------------------------------------ the roster

    async def _watch_roster(self) -> None:
        """Look at the roster every ``ROSTER_CHECK`` seconds; act on a change."""
        assert self._roster is not None
        stale = False  # a peer's session holds rules older than the roster
        while not self.closed:
            await asyncio.sleep(ROSTER_CHECK)
            roster = self._roster.poll()
            if roster is not None:
                try:
                    self._apply(roster)
                except Exception:
                    # The revoked are dropped all the same (``_revoked``); a failing
                    # driver costs only their leaving every group now.
                    log.exception("node %s: applying the roster failed", self.node_id)
                stale = self.options.mode == "peer"
            if stale and not self.closed:
                self._reopening = True
                try:
                    stale = not await self._reopen()
                finally:
                    self._reopening = False

    def _apply(self, roster: Roster) -> None:
        """Drop from now on what the ids the roster says are revoked send, and let the
        newly revoked leave every group."""
        revoked = frozenset(roster.revoked)
        self._revoked, before = revoked, self._revoked
        if self.node_id in revoked - before:
            log.error("node %s: our own certificate is revoked", self.node_id)
        for node in sorted(revoked - before - {self.node_id}):
            log.warning("node %s: %s is revoked: it leaves every group", self.node_id, node)
            self._count("peers_revoked")
            self.membership.forget(node)

    async def _reopen(self) -> bool:
        """Replace the session by one under the roster's rules now (closing every link:
        a revoked member's stay closed); True once the new one is open."""
        old, self._session = self._session, None
        inbox = self._inbox
        assert inbox is not None
        self.membership.suspend()
        inbox.forget_subscribers()
        self._queryables.clear()
        if old is not None:
            await self._close_session(old)
        try:
            session = await self._open_session()
        except OSError as exc:
            log.error("node %s: reopening the Zenoh session: %s", self.node_id, exc)
            self._count("reopen_failed")
            return False
        self._session = session
        self._declare(session)
        self._count("reopened")
        return True

    def peers(self) -> list[str]:
        """Nodes of the fleet whose liveliness token is up now, sorted."""
        return self.membership.peers()

    async def links_changed(self) -> None:
        """Wait until a node appears or goes (or the transport closes)."""
        await self.membership.changed()

    def _count(self, name: str, amount: int = 1) -> None:
        self.counters[name] = self.counters.get(name, 0) + amount

    # ------------------------------------------------------------------ outputs

    def transmit(self, output: Output) -> int:
        """Carry one output of the machine (never blocks: a congested put is dropped,
        and the session channels retransmit).

        Returns:
            How many puts went out.
        """
        if self.closed:
            return 0
        if self._session is None:  # being opened anew: what it must hold is kept
            self._remember(output)
            return 0
        keys = self.keys
        match output:
            case Send(target, data, _):
                return self._put(keys.to(target), data)
            case Broadcast(data, _):
                return self._put(keys.broadcast(), data)
            case Publish(cells, data, _, home, snapshot):
                before = self._home
                self._publishing_in(tuple(cells[:home]))
                sent = 0
                for n, cell in enumerate(cells):
                    # A cell new to our home gets the snapshot; its subscribers that
                    # heard us elsewhere too get both, the same publication twice.
                    payload = snapshot if snapshot is not None and cell not in before else data
                    sent += self._put(keys.props(cell, left=n > 0), payload)
                return sent
            case Subscribe(cells):
                self._subscribe(cells)
                return 0

    def _remember(self, output: Output) -> None:
        """Keep what a session being opened anew must declare (the frames go: the
        channels retransmit, the properties are asked again)."""
        match output:
            case Publish(cells, _, _, home, _):
                self._home = tuple(cells[:home])
            case Subscribe(cells):
                self._subscribed, self._subscription = True, cells
            case _:
                self._count("dropped_reopening")

    def _put(self, key: str, data: bytes) -> int:
        assert self._publishers is not None
        try:
            self._publishers.put(key, data)
        except zenoh.ZError:
            self._count("dropped_put_failed")
            return 0
        self._count("frames_out")
        self._count("bytes_out", len(data))
        return 1

    def _publishing_in(self, home: tuple[Cell, ...]) -> None:
        """Keep a queryable in every cell we publish in, so that askers there find us."""
        if home == self._home or self._session is None:
            return
        self._home = home
        wanted: tuple[Cell | None, ...] = home or (None,)
        assert self._inbox is not None
        for cell in wanted:  # the new ones first: an asker never finds a gap
            if cell not in self._queryables:
                self._queryables[cell] = self._session.declare_queryable(
                    self.keys.who(cell), self._inbox.query_callback()
                )
        for cell in [c for c in self._queryables if c not in wanted]:
            self._queryables.pop(cell).undeclare()

    def _subscribe(self, cells: frozenset[Cell] | None) -> None:
        session, keys, inbox = self._session, self.keys, self._inbox
        assert session is not None
        assert inbox is not None
        first = not self._subscribed
        was_full = self._subscribed and self._subscription is None
        self._subscribed = True
        self._subscription = cells
        asks: list[str] = []
        had = self._cells
        self._cells = frozenset() if cells is None else cells
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
            # loop (``_on_items``).
            rows = {cy for _, cy in cells}
            for row in [r for r in self._row_subs if r not in rows]:
                self._row_subs.pop(row).undeclare()
            for row in sorted(rows - self._row_subs.keys()):
                self._row_subs[row] = inbox.declare_data(session, keys.row_subscription(row), keys)
            asks += [keys.who_in(cell) for cell in sorted(cells - had)]
            if first:
                asks.append(keys.who_in(None))
        for selector in asks:
            self._ask(selector)

    def _ask(self, selector: str) -> None:
        """Ask the queryables matching ``selector`` for their properties, now and again
        a little later (``_ASK_AGAIN_AFTER``)."""
        self._ask_once(selector)
        loop = asyncio.get_running_loop()
        for delay in _ASK_AGAIN_AFTER:
            loop.call_later(delay, self._ask_once, selector)

    def _ask_once(self, selector: str) -> None:
        session = self._session
        if session is None or self.closed:
            return
        cells = None if self._subscription is None else sorted(self._subscription)
        payload = msgpack.packb([self.node_id, cells])
        try:
            session.get(selector, _IGNORE_REPLY, payload=payload, timeout=QUERY_TIMEOUT)
        except zenoh.ZError:
            self._count("dropped_query_failed")

    # ------------------------------------------------------------------ inputs

    def _on_items(self, items: list[Item]) -> None:
        """Hand what Zenoh delivered to the node, in arrival order (on the loop)."""
        driver = self._driver
        if driver is None or self.closed:
            return
        cells = self._cells  # empty: we hear every cell (or no cell yet)
        revoked = self._revoked
        frames: list[tuple[str, bytes]] = []
        size = outside = 0
        for item in items:
            if revoked and item[1] in revoked:
                self._count("dropped_revoked")
                continue
            if item[0] == "frame":  # nearly every item: the short way
                if cells and item[3] is not None and item[3] not in cells:
                    outside += 1  # another cell of a row we hear
                    continue
                frames.append((item[1], item[2]))
                size += len(item[2])
                continue
            if frames:  # in arrival order: the frames before this item first
                self._deliver(driver, frames)
                frames = []
            try:
                self._handle(driver, item)
            except Exception:
                # One input's failure costs that input, never the node.
                log.exception("node %s: handling %s failed", self.node_id, item[0])
                self._count("driver_errors")
        if frames:
            self._deliver(driver, frames)
        if size:
            self._count("bytes_in", size)
        if outside:
            self._count("frames_outside_cells", outside)

    def _deliver(self, driver: FrameDriver, frames: list[tuple[str, bytes]]) -> None:
        self._count("frames_in", len(frames))
        failed = driver.deliver_frames(frames)
        if failed:
            self._count("driver_errors", failed)

    def _handle(self, driver: FrameDriver, item: Item) -> None:
        match item:
            case ("alive", node, incarnation):
                self.membership.token_up(node, incarnation)
            case ("answer", node, incarnation, query):
                self.membership.answered(node, incarnation, query)
            case ("gone", node, incarnation):
                self.membership.token_down(node, incarnation)
            case ("query", asker, cells):
                if self._should_answer(cells):
                    driver.send_properties_to(asker)
            case _:
                self._count("dropped_unknown_item")

    def _ask_new_run(self, node: str) -> None:
        """A node appeared or restarted: ask it for its properties (once we hear cells)."""
        if self._subscribed:
            self._ask(self.keys.who_is(node))

    def _should_answer(self, cells: frozenset[Cell] | None) -> bool:
        """Whether an asker hearing ``cells`` (None: everything) should hear us."""
        return cells is None or not self._home or not cells.isdisjoint(self._home)


def _ignore_reply(_reply: zenoh.Reply) -> None:
    """Answers travel on the asker's inbox key, not as replies."""


_IGNORE_REPLY = direct(_ignore_reply)
