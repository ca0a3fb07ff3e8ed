"""The peer directory alone, on a fake clock: dialing, backoff, arbitration, gossip,
restarts, and forgetting gone peers so memory stays bounded."""

from __future__ import annotations

import random
from dataclasses import replace
from typing import Any

import pytest

from objectplaces.core.errors import LocalProtocolError
from objectplaces.transport.directory import Dial, LinkInfo, PeerDirectory
from objectplaces.transport.mesh_frames import PeerAddress
from objectplaces.transport.options import MeshOptions

OPTIONS = MeshOptions(
    backoff_initial=0.1, backoff_max=1.0, forget_after=10.0, gossip_interval=2.0, max_links=4,
    max_peers=8,
)  # fmt: skip


def directory(node: str = "m", seeds: tuple[str, ...] = (), **options: Any) -> PeerDirectory:
    opts = replace(OPTIONS, **options)
    return PeerDirectory(node, seeds=seeds, options=opts, rng=random.Random(1), now=0.0)


def link(d: PeerDirectory, peer: str, now: float, incarnation: int = 1) -> None:
    d.link_up(peer, f"h:{ord(peer[0])}", incarnation, now, replacing=False)


def test_seeds_are_dialed_at_once_then_with_bounded_backoff() -> None:
    d = directory(seeds=("h:1",), gossip_interval=100.0)
    assert d.tick(0.0).dials == (Dial("@h:1", "h:1"),)
    assert d.tick(0.0).dials == ()  # one dial at a time
    retries = []
    now = 0.0
    for _ in range(8):
        d.dial_finished("@h:1", None, "h:1", now)
        plan = d.tick(now)
        assert plan.dials == ()
        retries.append(plan.next_tick - now)
        now = plan.next_tick
        assert d.tick(now).dials == (Dial("@h:1", "h:1"),)
    ceilings = [min(1.0, 0.1 * 2**n) for n in range(8)]
    assert all(c / 2 <= r <= c for r, c in zip(retries, ceilings, strict=True)), retries


def test_a_reached_seed_keeps_its_name_and_stays_a_seed() -> None:
    d = directory(seeds=("h:1",))
    d.tick(0.0)
    d.dial_finished("@h:1", LinkInfo("s", 7, "m"), "h:1", 0.5)
    assert "@h:1" not in d
    assert d.incarnation("s") == 7
    d.link_up("s", "h:1", 7, 0.5, replacing=False)
    d.link_down("s", "1006 connection lost", 1.0, left=False)
    # a seed with a larger id than ours is still dialed, and never forgotten
    assert d.tick(1.0 + OPTIONS.backoff_max).dials == (Dial("s", "h:1"),)
    d.dial_finished("s", None, "h:1", 2.0)
    assert d.prune(1_000.0) == []
    assert "s" in d


def test_only_the_smaller_id_dials_a_gossiped_peer() -> None:
    d = directory("m")
    d.learn_gossip([PeerAddress("a", "h:1", 1), PeerAddress("z", "h:2", 1),
                    PeerAddress("m", "h:0", 1)], 0.0)  # fmt: skip
    assert "m" not in d  # never itself
    assert d.tick(0.0).dials == (Dial("z", "h:2"),)


def test_both_ends_keep_the_same_of_two_duplicate_links() -> None:
    a, b = directory("a"), directory("b")
    dialed_by_a, dialed_by_b = LinkInfo("b", 1, "a"), LinkInfo("b", 1, "b")
    seen_by_b = (LinkInfo("a", 1, "a"), LinkInfo("a", 1, "b"))
    assert a.keep_new(dialed_by_a, dialed_by_b)
    assert not a.keep_new(dialed_by_b, dialed_by_a)
    assert b.keep_new(*seen_by_b)
    assert not b.keep_new(seen_by_b[1], seen_by_b[0])
    # a newer run of the peer always wins
    assert a.keep_new(LinkInfo("b", 2, "b"), dialed_by_a)
    assert not a.keep_new(dialed_by_a, LinkInfo("b", 2, "b"))


def test_a_new_run_of_a_peer_is_reported_once_and_reconnects_are_counted() -> None:
    d = directory()
    counters, restarted = d.link_up("p", "h:1", 1, 0.0, replacing=False)
    assert not restarted
    d.link_down("p", "1006 connection lost", 1.0, left=False)
    counters, restarted = d.link_up("p", "h:1", 1, 2.0, replacing=False)
    assert (restarted, counters.links, counters.reconnects) == (False, 2, 1)
    counters, restarted = d.link_up("p", "h:1", 2, 3.0, replacing=True)  # a new run
    assert (restarted, counters.links, counters.reconnects) == (True, 3, 1)
    assert d.stats()["p"].connected


def test_a_peer_that_left_is_not_redialed_until_a_newer_run_is_gossiped() -> None:
    d = directory("a")
    link(d, "p", 0.0)
    d.link_down("p", "1001 leaving", 1.0, left=True)
    assert d.tick(5.0).dials == ()
    d.learn_gossip([PeerAddress("p", "h:9", 1)], 6.0)  # the same run: still gone
    assert d.tick(6.0).dials == ()
    d.learn_gossip([PeerAddress("p", "h:9", 2)], 7.0)  # a new run
    assert d.tick(7.0).dials == (Dial("p", "h:9"),)


def tick_failing_dials(d: PeerDirectory, now: float) -> None:
    """Tick; every dial due fails at once (the peer is unreachable)."""
    for dial in d.tick(now).dials:
        d.dial_finished(dial.key, None, dial.address, now)


def test_gone_and_lost_peers_are_forgotten_after_forget_after() -> None:
    d = directory("a", seeds=("h:1",))
    for peer in ("gone", "lost", "linked"):
        link(d, peer, 0.0)
    d.link_down("gone", "1001 leaving", 1.0, left=True)
    d.link_down("lost", "1006 connection lost", 2.0, left=False)
    d.learn_gossip([PeerAddress("heard", "h:5", 1)], 3.0)
    tick_failing_dials(d, 10.9)
    assert {"gone", "lost", "linked"} <= set(d.stats())
    tick_failing_dials(d, 11.1)  # 10 s after "gone" went: forgotten, counters and all
    assert "gone" not in d
    assert "gone" not in d.stats()
    assert "lost" in d
    tick_failing_dials(d, 12.1)
    assert "lost" not in d
    assert "heard" in d
    tick_failing_dials(d, 13.1)  # only gossiped about, 10 s ago
    assert "heard" not in d
    tick_failing_dials(d, 1_000.0)
    assert "linked" in d
    assert "@h:1" in d
    assert len(d) == 2
    # a forgotten peer that comes back is a newcomer: no restart is reported
    counters, restarted = d.link_up("gone", "h:3", 5, 1_001.0, replacing=False)
    assert (restarted, counters.links, counters.reconnects) == (False, 1, 0)


def test_gossip_never_grows_the_directory_past_max_peers() -> None:
    d = directory("a", seeds=("h:1",))
    link(d, "b", 0.0)
    for n in range(100):
        d.learn_gossip([PeerAddress(f"p{n:03}", f"h:{n + 10}", 1)], float(n))
        assert len(d) <= OPTIONS.max_peers
    assert "@h:1" in d
    assert "b" in d
    assert "p099" in d
    assert "p000" not in d
    # a link is always recorded, even when every entry is a seed or linked
    full = directory("a", max_peers=4, max_links=4)
    for peer in "bcde":
        link(full, peer, 0.0)
    full.learn_gossip([PeerAddress("x", "h:99", 1)], 1.0)
    assert "x" not in full
    link(full, "f", 1.0)
    assert "f" in full


def test_gossip_names_this_node_and_its_linked_peers() -> None:
    d = directory("a")
    link(d, "c", 0.0)
    link(d, "b", 0.0)
    link(d, "d", 0.0)
    d.link_down("d", "1006 connection lost", 1.0, left=False)
    own = PeerAddress("a", "h:0", 9)
    assert d.gossip(own) == [own, PeerAddress("b", "h:98", 1), PeerAddress("c", "h:99", 1)]
    assert not d.tick(1.9).gossip
    assert d.tick(2.0).gossip
    assert not d.tick(3.9).gossip
    assert d.tick(4.0).gossip


def test_options_are_checked() -> None:
    with pytest.raises(LocalProtocolError, match="forget_after must be > 0, got 0"):
        MeshOptions(forget_after=0)
    with pytest.raises(LocalProtocolError, match="max_peers must be >= max_links"):
        MeshOptions(max_links=10, max_peers=5)
