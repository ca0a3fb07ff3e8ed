"""The Zenoh transport: one node's session, its keys, and the frames it moves (asyncio).

Outputs of the node machine become puts on the fleet's keys (``zenoh_keys``): ``Publish``
on the cell keys, ``Broadcast`` on the node's broadcast key, ``Send`` on the target's
inbox key. ``Subscribe`` and the cells published in change what the node declares
(``zenoh_declared``).

Membership is Zenoh's liveliness: every node holds a token while its session lives; a
node whose token goes (it left, its process died, its links lapsed past the lease) and
is not back within the grace (``ZenohOptions.token_grace``; a token redeclared as routes
change is) is gone, and the machine lets it leave every group then, with no heartbeat of
ours. An asked node whose properties the asker should hear sends it a snapshot on its
inbox key.

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
from typing import Protocol

from objectplaces.core.events import Broadcast, Output, Publish, Send, Subscribe
from objectplaces.security.identity import Identity
from objectplaces.transport.base import RawNodeDriver
from objectplaces.transport.zenoh_acl import Roster, fleet_access_control
from objectplaces.transport.zenoh_config import (
    Credentials,
    CredentialsFile,
    ZenohOptions,
    ZenohSecurity,
    derive_credentials,
    zenoh_config,
)
from objectplaces.transport.zenoh_declared import Declared
from objectplaces.transport.zenoh_inbox import Item, ZenohInbox
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.transport.zenoh_lib import zenoh
from objectplaces.transport.zenoh_membership import Membership
from objectplaces.transport.zenoh_publishers import PublisherCache
from objectplaces.transport.zenoh_roster import ROSTER_CHECK, RosterWatch

__all__ = ["FrameDriver", "ZenohTransport"]

log = logging.getLogger("objectplaces.zenoh")


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
        tag: str = "",
    ) -> None:
        self.node_id = node_id
        self.options = options
        self.incarnation = incarnation
        self.keys = FleetKeys(options.fleet, node_id, tag)

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
        self._declared: Declared | None = None
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
        self._declared = Declared(
            self.keys, self._inbox, self.membership, self.counters, incarnation=self.incarnation
        )
        self._use(self._session)
        if self._roster is not None:
            self._watcher = loop.create_task(self._watch_roster())

    async def _open_session(self) -> zenoh.Session:
        config = zenoh_config(self.options, self._security())
        try:
            return await asyncio.to_thread(zenoh.open, config)
        except zenoh.ZError as exc:
            raise OSError(f"zenoh: {exc}") from exc

    def _use(self, session: zenoh.Session) -> None:
        """Put on ``session`` from now on, and declare there what this node holds."""
        assert self._declared is not None
        self._session = session
        self._publishers = PublisherCache(session)
        self._declared.declare(session)

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
        if self._declared is not None:
            self._declared.drop()
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
        assert self._declared is not None
        self._declared.drop()
        if old is not None:
            await self._close_session(old)
        try:
            session = await self._open_session()
        except OSError as exc:
            log.error("node %s: reopening the Zenoh session: %s", self.node_id, exc)
            self._count("reopen_failed")
            return False
        self._use(session)
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
        declared = self._declared
        if self.closed or declared is None:
            return 0
        keys = self.keys
        match output:
            case Send(target, data, _):
                return self._put(keys.to(target), data)
            case Broadcast(data, _):
                return self._put(keys.broadcast(), data)
            case Publish(cells, data, _, home, snapshot):
                before = declared.home
                declared.publishing_in(tuple(cells[:home]))
                sent = 0
                for n, cell in enumerate(cells):
                    # A cell new to our home gets the snapshot; its subscribers that
                    # heard us elsewhere too get both, the same publication twice.
                    payload = snapshot if snapshot is not None and cell not in before else data
                    sent += self._put(keys.props(cell, left=n > 0), payload)
                return sent
            case Subscribe(cells):
                declared.subscribe(cells)
                return 0

    def _put(self, key: str, data: bytes) -> int:
        if self._session is None or self._publishers is None:
            self._count("dropped_reopening")  # the channels retransmit
            return 0
        try:
            self._publishers.put(key, data)
        except zenoh.ZError:
            self._count("dropped_put_failed")
            return 0
        self._count("frames_out")
        self._count("bytes_out", len(data))
        return 1

    # ------------------------------------------------------------------ inputs

    def _on_items(self, items: list[Item]) -> None:
        """Hand what Zenoh delivered to the node, in arrival order (on the loop)."""
        driver = self._driver
        if driver is None or self.closed:
            return
        # Empty: we hear every cell (or no cell yet).
        cells = self._declared.cells if self._declared is not None else frozenset()
        revoked, foreign = self._revoked, self.membership.foreign
        frames: list[tuple[str, bytes]] = []
        size = outside = 0
        for item in items:
            if revoked and item[1] in revoked:
                self._count("dropped_revoked")
                continue
            if foreign and item[1] in foreign:
                self._count("dropped_foreign")
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
            case ("alive", node, incarnation, tag):
                self.membership.token_up(node, incarnation, tag)
            case ("answer", node, incarnation, tag, query):
                self.membership.answered(node, incarnation, tag, query)
            case ("gone", node, incarnation, _tag):
                self.membership.token_down(node, incarnation)
            case ("query", asker, cells):
                if self._declared is None or self._declared.should_answer(cells):
                    driver.send_properties_to(asker)
            case _:
                self._count("dropped_unknown_item")

    def _ask_new_run(self, node: str) -> None:
        """A node appeared or restarted: ask it for its properties (once we hear cells)."""
        if self._declared is not None:
            self._declared.ask_new_run(node)
