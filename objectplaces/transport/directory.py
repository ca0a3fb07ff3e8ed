"""The mesh's peer directory: whom a node knows, whom it dials, which link stays (sans-I/O).

A node learns peers three ways: its seeds (``--join``), the peers that link with it,
and gossip (each peer tells the others whom it is linked to). For each it keeps where
the peer listens and which run of it (the incarnation; a restart has a larger one).

Dialing: for a pair that is not linked, the node with the smaller id dials, and a node
always dials its seeds, each with bounded exponential backoff and jitter, so a restarted
node is found again by whoever knew it. A peer that left for good is not dialed again
unless gossip brings a newer run of it.

Duplicate links: when both sides dial at once, both ends keep the same link: the newer
incarnation's, else the one the smaller id dialed.

Bounded memory: a peer without a link for ``forget_after`` seconds is forgotten, entry,
incarnation and counters alike, whether it left, was lost or was only gossiped about;
seeds stay. At most ``max_peers`` entries: a newcomer evicts the longest-unseen peer
without a link, and gossip about more peers is dropped while none can make room.

``tick(now)`` returns the dials due, whether to gossip, and when to be ticked again;
the asyncio shell does the rest. Randomness (backoff jitter) comes from an injected rng.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

from objectplaces.transport.mesh_frames import PeerAddress
from objectplaces.transport.options import MeshOptions, PeerStats

__all__ = ["Dial", "DirectoryTick", "LinkInfo", "PeerCounters", "PeerDirectory", "Rng"]


class Rng(Protocol):
    """The randomness the directory needs (``random.Random`` fits)."""

    def uniform(self, a: float, b: float) -> float:
        """A float drawn uniformly from [a, b]."""
        ...


@dataclass(slots=True)
class PeerCounters:
    """Traffic with one peer, kept as long as the directory remembers the peer."""

    address: str = ""
    links: int = 0
    reconnects: int = 0
    messages_in: int = 0
    bytes_in: int = 0
    messages_out: int = 0
    bytes_out: int = 0
    drops: int = 0
    last_close: str = ""


@dataclass(slots=True)
class _Peer:
    """What the node knows of one peer (keyed ``@address``: a seed not yet reached)."""

    address: str
    incarnation: int = 0
    seed: bool = False
    gone: bool = False
    linked: bool = False
    dialing: bool = False
    attempts: int = 0
    next_dial: float = 0.0
    last_seen: float = 0.0
    linked_incarnation: int | None = None
    counters: PeerCounters | None = None


@dataclass(frozen=True, slots=True)
class Dial:
    """Dial ``address``; report the result under ``key`` (``dial_finished``)."""

    key: str
    address: str


@dataclass(frozen=True, slots=True)
class DirectoryTick:
    """What to do now: the dials due, whether to gossip, when to tick again."""

    dials: tuple[Dial, ...]
    gossip: bool
    next_tick: float


@dataclass(frozen=True, slots=True)
class LinkInfo:
    """One authenticated link, as duplicate-link arbitration sees it."""

    peer: str
    incarnation: int
    dialer: str


class PeerDirectory:
    """Known peers, dial decisions, link arbitration and gossip of one mesh node.

    Args:
        node_id: this node's id.
        seeds: ``host:port`` of the nodes to join through (always dialed).
        options: ``backoff_*``, ``forget_after``, ``gossip_interval``, ``max_peers``.
        rng: draws the backoff jitter.
        now: the time at creation (None: the gossip timer starts at the first tick).
    """

    def __init__(
        self,
        node_id: str,
        *,
        seeds: Iterable[str],
        options: MeshOptions,
        rng: Rng,
        now: float | None = None,
    ) -> None:
        self.node_id = node_id
        self.options = options
        self._rng = rng
        self._peers: dict[str, _Peer] = {f"@{a}": _Peer(a, seed=True) for a in seeds}
        self._next_gossip: float | None = None if now is None else now + options.gossip_interval

    def __len__(self) -> int:
        """How many peers (and seeds not reached yet) the directory holds."""
        return len(self._peers)

    def __contains__(self, peer: object) -> bool:
        return peer in self._peers

    def incarnation(self, peer: str) -> int | None:
        """The newest run of ``peer`` known (None: not known)."""
        known = self._peers.get(peer)
        return None if known is None else known.incarnation

    # ------------------------------------------------------------------ time

    def tick(self, now: float) -> DirectoryTick:
        """Forget expired peers; say which dials are due, whether to gossip, and when next.

        A returned dial is marked in progress until ``dial_finished``.
        """
        self.prune(now)
        if self._next_gossip is None:
            self._next_gossip = now + self.options.gossip_interval
        next_tick = self._next_gossip
        gossip = now >= next_tick
        if gossip:
            next_tick = self._next_gossip = now + self.options.gossip_interval
        dials: list[Dial] = []
        for key in sorted(self._peers):
            known = self._peers[key]
            if not self._wants_dial(key, known):
                continue
            if known.next_dial <= now:
                known.dialing = True
                dials.append(Dial(key, known.address))
            else:
                next_tick = min(next_tick, known.next_dial)
        return DirectoryTick(tuple(dials), gossip, next_tick)

    def prune(self, now: float) -> list[str]:
        """Forget every peer without a link for ``forget_after`` seconds (seeds stay).

        Returns:
            The peers forgotten, sorted.
        """
        limit = now - self.options.forget_after
        expired = sorted(k for k, p in self._peers.items() if self._idle(p) and p.last_seen < limit)
        for key in expired:
            del self._peers[key]
        return expired

    def _wants_dial(self, key: str, known: _Peer) -> bool:
        if known.dialing or known.gone or known.linked:
            return False
        return known.seed or self.node_id < key

    @staticmethod
    def _idle(known: _Peer) -> bool:
        return not (known.seed or known.linked or known.dialing)

    # ------------------------------------------------------------------ dialing

    def dial_finished(
        self, key: str, established: LinkInfo | None, address: str, now: float
    ) -> None:
        """Report a dial of ``key``: ``established`` is the link it gave (None: it failed)."""
        known = self._peers.get(key)
        if known is None:
            return
        known.dialing = False
        if established is None:
            known.next_dial = now + self._backoff(known.attempts)
            known.attempts += 1
            return
        if key.startswith("@"):
            # The seed has a name now; keep dialing it by name, as a seed.
            del self._peers[key]
            known = self._learn(established.peer, address, established.incarnation, now, seed=True)
        if known is not None:
            known.attempts = 0

    def _backoff(self, attempts: int) -> float:
        options = self.options
        ceiling = min(options.backoff_max, options.backoff_initial * 2.0 ** min(attempts, 64))
        return ceiling * self._rng.uniform(0.5, 1.0)

    # ------------------------------------------------------------------ links

    def keep_new(self, new: LinkInfo, old: LinkInfo) -> bool:
        """Which of two links to one peer stays (both ends reach the same answer)."""
        if new.incarnation != old.incarnation:
            return new.incarnation > old.incarnation
        if new.dialer != old.dialer:
            return new.dialer == min(self.node_id, new.peer)
        return True

    def link_up(
        self, peer: str, address: str, incarnation: int, now: float, *, replacing: bool
    ) -> tuple[PeerCounters, bool]:
        """A link to ``peer`` is up (``replacing`` another link to it that was up).

        Returns:
            The peer's counters, and whether the link shows that the peer restarted
            (a run other than the one last linked).
        """
        known = self._learn(peer, address, incarnation, now, force=True)
        assert known is not None
        known.gone = False
        known.linked = True
        known.attempts = 0
        counters = known.counters
        if counters is None:
            counters = known.counters = PeerCounters()
        counters.address = address
        if not replacing and counters.links:
            counters.reconnects += 1
        counters.links += 1
        previous, known.linked_incarnation = known.linked_incarnation, incarnation
        return counters, previous is not None and previous != incarnation

    def link_down(self, peer: str, reason: str, now: float, *, left: bool) -> None:
        """The link to ``peer`` closed for ``reason``; ``left``: the peer left for good."""
        known = self._peers.get(peer)
        if known is None:
            return
        known.linked = False
        known.last_seen = now
        known.next_dial = now + self._backoff(0)
        known.gone = left
        if known.counters is not None:
            known.counters.last_close = reason

    def counters(self, peer: str) -> PeerCounters | None:
        """The traffic counters of ``peer`` (None: never linked, or forgotten)."""
        known = self._peers.get(peer)
        return None if known is None else known.counters

    # ------------------------------------------------------------------ gossip

    def gossip(self, own: PeerAddress) -> list[PeerAddress]:
        """What to tell peers: this node, then every peer linked now, sorted."""
        entries = [own]
        for peer in sorted(self._peers):
            known = self._peers[peer]
            if known.linked:
                entries.append(PeerAddress(peer, known.address, known.incarnation))
        return entries

    def learn_gossip(self, peers: Iterable[PeerAddress], now: float) -> None:
        """Take a peer's gossip: news of peers, or of newer runs of them."""
        for entry in peers:
            if entry.node == self.node_id:
                continue
            known = self._peers.get(entry.node)
            if known is None or entry.incarnation >= known.incarnation:
                self._learn(entry.node, entry.address, entry.incarnation, now)

    def _learn(
        self,
        peer: str,
        address: str,
        incarnation: int,
        now: float,
        *,
        seed: bool = False,
        force: bool = False,
    ) -> _Peer | None:
        """Record where ``peer`` listens; a newer incarnation replaces an older one.

        Returns None when the directory is full and ``force`` is not set.
        """
        known = self._peers.get(peer)
        if known is None:
            if not self._make_room() and not (force or seed):
                return None
            known = self._peers[peer] = _Peer(address, incarnation, seed=seed)
        elif incarnation > known.incarnation:
            known.address, known.incarnation = address, incarnation
            known.gone = False
            known.attempts = 0
            known.next_dial = now
        known.seed = known.seed or seed
        known.last_seen = now
        return known

    def _make_room(self) -> bool:
        """Keep below ``max_peers``: evict the longest-unseen idle peer if need be."""
        if len(self._peers) < self.options.max_peers:
            return True
        idle = [(p.last_seen, k) for k, p in self._peers.items() if self._idle(p)]
        if not idle:
            return False
        del self._peers[min(idle)[1]]
        return True

    # ------------------------------------------------------------------ statistics

    def stats(self) -> dict[str, PeerStats]:
        """Traffic counters of every remembered peer that has been linked, by id."""
        out = {}
        for peer in sorted(self._peers):
            known = self._peers[peer]
            c = known.counters
            if c is not None:
                out[peer] = PeerStats(
                    c.address,
                    known.linked,
                    c.links,
                    c.reconnects,
                    c.messages_in,
                    c.bytes_in,
                    c.messages_out,
                    c.bytes_out,
                    c.drops,
                    c.last_close,
                )
        return out
