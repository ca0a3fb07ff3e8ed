"""A node at rest (docs/protocol.md §2): it beats less often, its peers wait for it that
much longer, and no loss the usual timeout survives makes it count as failed."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.events import Broadcast, Send
from objectplaces.core.messages import Beat, PropertyRequest, PropertyUpdate
from objectplaces.core.node import NodeMachine

from .wire import Wire

RESTING = NodeConfig(property_interval=600.0, beat_interval=1.0, rest_beat_interval=5.0)
"""Beats every second, every five at rest: a resting peer fails after 15 s unheard."""


def pair(
    config: NodeConfig = RESTING, other: NodeConfig | None = None
) -> tuple[Wire, NodeMachine, NodeMachine]:
    a, b = NodeMachine("a", config=config), NodeMachine("b", config=other or config)
    wire = Wire(a, b)
    a.update_property("position", (1.0, 2.0), 0.0)
    b.update_property("position", (3.0, 4.0), 0.0)
    wire.settle()
    return wire, a, b


def beat_times(
    wire: Wire, source: str = "a", target: str = "b"
) -> list[tuple[float, float | None]]:
    """When ``source`` beat to ``target``, and the rest each beat declared (from the log)."""
    return [
        (t, m.rest)
        for (s, d, m), t in zip(wire.log, wire.sent_at, strict=True)
        if s == source and d == target and isinstance(m, Beat)
    ]


def test_the_longest_lease_scales_the_timeout_by_the_rest() -> None:
    assert RESTING.longest_lease == 15.0
    assert NodeConfig(beat_interval=1.0).longest_lease == 3.0
    assert (
        NodeConfig(beat_interval=2.0, rest_beat_interval=8.0, failure_timeout=5.0).longest_lease
        == 20.0
    )
    assert NodeConfig().longest_lease is None


@pytest.mark.parametrize(
    ("config", "message"),
    [
        (NodeConfig(rest_beat_interval=5.0), "needs a beat_interval"),
        (NodeConfig(beat_interval=2.0, rest_beat_interval=1.0), "at least beat_interval"),
        (NodeConfig(beat_interval=1.0, rest_beat_interval=float("inf")), "at most a day"),
        (NodeConfig(beat_interval=1.0, rest_beat_interval=90_000.0), "at most a day"),
        (NodeConfig(beat_interval=1.0, rest_beat_interval=float("nan")), "must be > 0"),
        (NodeConfig(beat_interval=1.0, rest_beat_interval=0.0), "must be > 0"),
    ],
)
def test_a_bad_rest_interval_is_refused(config: NodeConfig, message: str) -> None:
    with pytest.raises(LocalProtocolError, match=message):
        NodeMachine("a", config=config)


def test_at_rest_a_node_announces_its_rest_at_the_usual_interval_then_beats_rarely() -> None:
    wire, a, _ = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(30.0)
    beats = beat_times(wire)
    # three beats a second apart (a failure timeout of them) that announce the rest,
    # then a plain one every five
    assert [t for t, _ in beats] == [1.0, 2.0, 3.0, 8.0, 13.0, 18.0, 23.0, 28.0]
    assert [rest for _, rest in beats] == [5.0, 5.0, 5.0, None, None, None, None, None]


def test_the_plain_beats_after_the_announcement_keep_the_rest_granted() -> None:
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(18.5)  # announced at 1, 2, 3; plain beats at 8, 13, 18
    del wire.machines["a"]
    wire.run_until(18.0 + 15.0 - 0.01)
    assert "a" in b.view()
    wire.run_until(18.0 + 15.0 + 1.0)
    assert "a" not in b.view()


def test_a_peer_waits_for_a_resting_node_as_long_as_its_rest_allows() -> None:
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(13.5)  # the last beat was at 13
    del wire.machines["a"]  # a crashes, at rest
    wire.run_until(13.0 + 15.0 - 0.01)
    assert "a" in b.view()  # three rest intervals not yet over
    wire.run_until(13.0 + 15.0 + 1.0)  # liveness is looked at every second
    assert "a" not in b.view()
    assert b.counters["departed_failed"] == 1


def test_a_publication_ends_the_rest_at_every_receiver() -> None:
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(10.0)
    a.update_property("status", "moved", wire.now)  # publishes: beats as usual follow
    wire.run_until(10.5)
    del wire.machines["a"]
    wire.run_until(10.0 + 3.0 - 0.01)
    assert "a" in b.view()
    wire.run_until(10.0 + 4 / 3 * 3.0)
    assert "a" not in b.view()  # the usual timeout again


def test_after_a_publication_at_rest_the_rest_is_announced_again() -> None:
    wire, a, _ = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(10.0)
    a.update_property("status", "moved", wire.now)
    wire.run_until(30.0)
    after = [t for t, _ in beat_times(wire) if t > 10.0]
    assert after == [11.0, 12.0, 13.0, 18.0, 23.0, 28.0]


def test_leaving_rest_brings_the_usual_beat_back_within_an_interval() -> None:
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(9.0)  # beats at 1, 2, 3, 8
    a.set_at_rest(False, wire.now)
    wire.run_until(12.0)
    beats = beat_times(wire)
    assert beats[4:] == [(10.0, 0.0), (11.0, 0.0), (12.0, 0.0)]  # the rest ended
    del wire.machines["a"]
    wire.run_until(12.0 + 4 / 3 * 3.0)
    assert "a" not in b.view()  # the usual timeout again at b


def test_after_saying_its_rest_ended_a_node_beats_plainly() -> None:
    wire, a, _ = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(9.0)
    a.set_at_rest(False, wire.now)
    wire.run_until(15.0)
    assert [r for _, r in beat_times(wire)][4:] == [0.0, 0.0, 0.0, None, None, None]


def test_a_node_that_never_declared_its_rest_does_not_say_it_ended() -> None:
    wire, a, _ = pair()
    a.set_at_rest(True, 0.0)
    a.set_at_rest(False, 0.5)  # before its first beat
    wire.run_until(4.0)
    assert beat_times(wire) == [(1.0, None), (2.0, None), (3.0, None), (4.0, None)]


def test_a_receiver_that_lost_every_end_of_the_rest_only_finds_a_failure_later() -> None:
    """It keeps the longer wait until the node publishes: never a live node failed."""
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(9.0)
    a.set_at_rest(False, wire.now)
    for _ in range(3):  # the three beats that say the rest ended, lost
        deadline = a.next_deadline()
        assert deadline is not None
        a.tick(deadline)
        wire.now = deadline
        a.messages_to_send()
    assert wire.now == 12.0
    wire.run_until(20.0)  # plain beats, every second
    assert "a" in b.view()
    del wire.machines["a"]
    wire.run_until(20.0 + 15.0 - 0.01)
    assert "a" in b.view()  # the rest it still grants
    wire.run_until(20.0 + 15.0 + 1.0)
    assert "a" not in b.view()


def test_without_a_rest_interval_being_at_rest_changes_nothing() -> None:
    plain = NodeConfig(property_interval=600.0, beat_interval=1.0)
    wire, a, _ = pair(plain)
    a.set_at_rest(True, 0.0)
    wire.run_until(5.0)
    assert beat_times(wire) == [(float(t), None) for t in range(1, 6)]


def test_a_receiver_grants_no_more_rest_than_its_own_configuration_allows() -> None:
    """A peer may declare any rest up to a day; the receiver waits at most its own."""
    _, _, b = pair()
    b.receive("a", codec.encode(Beat(1, 3600.0)), now=1.0)
    b.tick(1.0 + 14.5)
    assert "a" in b.view()
    b.tick(1.0 + 15.0 + 1.01)
    assert "a" not in b.view()  # 15 s, not three hours


def test_a_receiver_without_rest_waits_the_usual_timeout() -> None:
    plain = NodeConfig(property_interval=600.0, beat_interval=1.0)
    _, _, b = pair(RESTING, plain)
    b.receive("a", codec.encode(Beat(1, 5.0)), now=1.0)
    b.tick(1.0 + 4 / 3 * 3.0)
    assert "a" not in b.view()


def test_rest_beats_from_strangers_add_nothing() -> None:
    b = NodeMachine("b", config=RESTING)
    for i in range(50):
        b.receive("stranger", codec.encode(Beat(i, 86_400.0)), now=i * 0.1)
    assert b.view() == {}
    assert b.footprint()["resting"] == b.footprint()["heard"] == 0


@settings(max_examples=200, deadline=None)
@given(lost=st.sets(st.integers(0, 11), max_size=12), crash_after=st.integers(0, 11))
def test_no_loss_the_usual_timeout_survives_makes_a_resting_node_fail(
    lost: set[int], crash_after: int
) -> None:
    """Any beats may be lost, but never three in a row (what a timeout of three
    intervals survives); the live node stays in the view, and once it crashes it is
    found within its lease plus a liveness check."""
    lost = {n for n in lost if not {n - 1, n - 2} <= lost}  # at most two in a row
    wire, a, b = pair()
    a.set_at_rest(True, 0.0)
    sent = 0
    last_heard, lease = 0.0, 3.0  # a's publication at 0: the usual timeout
    for _ in range(12):
        deadline = a.next_deadline()
        assert deadline is not None
        a.tick(deadline)
        wire.now = deadline
        for output in a.messages_to_send():
            assert isinstance(output, Broadcast)  # beats, to everyone
            if sent not in lost:
                b.receive("a", output.data, deadline)
                last_heard, lease = deadline, 15.0
            sent += 1
        b.tick(deadline)
        assert "a" in b.view(), f"a counted failed at {deadline} with beats {sorted(lost)} lost"
        if sent > crash_after:
            break
    b.tick(last_heard + lease - 0.01)
    assert "a" in b.view()
    b.tick(last_heard + lease + 1.0)
    assert "a" not in b.view()


def test_a_republication_at_rest_announces_the_rest_again() -> None:
    config = NodeConfig(property_interval=20.0, beat_interval=1.0, rest_beat_interval=5.0)
    wire, a, b = pair(config)
    a.set_at_rest(True, 0.0)
    wire.run_until(45.0)
    after = [t for t, _ in beat_times(wire) if 20.0 < t <= 40.0]
    assert after == [21.0, 22.0, 23.0, 28.0, 33.0, 38.0]
    assert "departed_failed" not in b.counters


def test_a_newcomer_given_a_snapshot_hears_the_rest_announced_again() -> None:
    wire, a, _ = pair()
    a.set_at_rest(True, 0.0)
    wire.run_until(20.0)
    c = wire.machines["c"] = NodeMachine("c", config=RESTING)
    a.peer_joined("c", wire.now)  # c holds a from a snapshot: it expects usual beats
    wire.run_until(60.0)
    assert "a" in c.view()
    assert "departed_failed" not in c.counters
    # Three beats of its own (the one at 23 twice: the beat to all falls due then too),
    # then every five seconds with the others; b, which knew of the rest, gets no more.
    assert [t for t, _ in beat_times(wire, "a", "c")][:6] == [21.0, 22.0, 23.0, 23.0, 28.0, 33.0]
    assert [t for t, _ in beat_times(wire, "a", "b") if t > 15.0][:4] == [18.0, 23.0, 28.0, 33.0]


_OPS = st.one_of(
    st.tuples(st.just("rest"), st.booleans()),
    st.tuples(st.just("publish"), st.integers(0, 5)),
    st.tuples(st.just("wait"), st.floats(0.1, 20.0)),
    st.tuples(st.just("newcomer"), st.none()),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(_OPS, max_size=20))
def test_on_a_lossless_network_no_peer_ever_counts_a_live_node_failed(
    ops: list[tuple[str, object]],
) -> None:
    """Rest, wake, publish, republish, newcomers, in any order: a live node stays in
    every view (the rest is announced wherever a peer expects the usual beats), and a
    node that is awake, once it has beaten a timeout's worth, is waited for no longer
    than usual (its end of the rest reached every peer that granted it)."""
    config = NodeConfig(property_interval=13.0, beat_interval=1.0, rest_beat_interval=5.0)
    wire, a, _ = pair(config)
    resting = False
    for n, (op, arg) in enumerate(ops):
        match op:
            case "rest":
                resting = bool(arg)
                a.set_at_rest(resting, wire.now)
            case "publish":
                a.update_property("status", arg, wire.now)
            case "wait":
                assert isinstance(arg, float)
                wire.run_until(wire.now + arg)
            case _:
                wire.machines[f"c{n}"] = NodeMachine(f"c{n}", config=config)
                a.peer_joined(f"c{n}", wire.now)
        wire.settle()
        for name, machine in wire.machines.items():
            if name != "a":
                assert "a" in machine.view(), f"{name} lost a at {wire.now} after {ops[: n + 1]}"
    wire.run_until(wire.now + 40.0)
    assert all("a" in m.view() for name, m in wire.machines.items() if name != "a")
    if not resting:
        for name, machine in wire.machines.items():
            if name != "a":
                assert machine._view._resting.extra("a") == 0.0, f"{name} still grants a rest"


def test_a_peer_that_forgets_a_resting_node_and_asks_at_each_beat_stops_asking() -> None:
    """A peer that left the node's scope drops it at each snapshot, and asks again at
    each beat it gets from a node it does not hold: the beats of its own stop that."""
    a = NodeMachine("a", config=RESTING)
    a.update_property("position", (1.0, 2.0), 0.0)
    a.set_at_rest(True, 0.0)
    a.messages_to_send()
    a.send_properties_to("p", 0.0)
    to_p: list[tuple[float, object]] = []
    now = 0.0
    while now < 60.0:
        deadline = a.next_deadline()
        assert deadline is not None
        now = deadline
        a.tick(now)
        for output in a.messages_to_send():
            if isinstance(output, Send) and output.target == "p":
                message = codec.decode(output.data)
                to_p.append((now, message))
                if isinstance(message, Beat):  # p does not hold a: it asks
                    a.receive("p", codec.encode(PropertyRequest()), now)
    beats = [t for t, m in to_p if isinstance(m, Beat)]
    snapshots = [t for t, m in to_p if isinstance(m, PropertyUpdate)]
    assert beats == [1.0, 2.0, 3.0]
    assert len(snapshots) == 4  # the first, the answers to those three, and no more
