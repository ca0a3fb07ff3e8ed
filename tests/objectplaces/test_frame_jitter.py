"""One jitter draw per frame (``jitter_per_frame``) against one per receiver.

With it, a frame over links that only delay and jitter reaches all its receivers at one
instant, in one event; every other link keeps its own draws, and without jitter the two
models are the same run.
"""

from __future__ import annotations

import random
from collections import defaultdict
from typing import Any

from objectplaces.core import codec
from objectplaces.core.events import Broadcast, Send
from objectplaces.core.messages import PropertyUpdate
from objectplaces.runtime.sim import EventLoop
from objectplaces.sim import SimulatedNetwork
from objectplaces.transport.memory import LinkParams, MemoryNetwork

Arrival = tuple[str, str, float]  # source, receiver, when


class _Driver:
    def __init__(self, name: str, log: list[Arrival], loop: EventLoop) -> None:
        self.name, self.log, self.loop = name, log, loop

    def deliver(self, source: str, message: Any, size: int) -> None:
        self.log.append((source, self.name, self.loop.now))

    def deliver_raw(self, source: str, data: bytes) -> None:
        self.log.append((source, self.name, self.loop.now))

    def peer_joined(self, peer: str) -> None:
        """Not used here."""

    def peer_restarted(self, peer: str) -> None:
        """Not used here."""

    def send_properties_to(self, peer: str) -> None:
        """Not used here."""


_FRAME = codec.encode(PropertyUpdate(1, {"x": 1}))


def _run(
    params: LinkParams, *, per_frame: bool, slow_link: bool = False
) -> tuple[list[Arrival], int]:
    """Three nodes broadcast to six and one sends to one; the arrivals and events run."""
    loop = EventLoop()
    log: list[Arrival] = []
    net = MemoryNetwork(loop, random.Random(5), params, jitter_per_frame=per_frame)
    for name in "abcdef":
        net.attach(name, _Driver(name, log, loop))
    if slow_link:
        net.set_link("a", "f", delay=0.05)
    for sender in "abc":
        net.transmit(sender, Broadcast(_FRAME, "property"))
    net.transmit("d", Send("e", _FRAME, "property"))
    loop.run_until(1.0)
    return log, loop.events_run


def _instants(log: list[Arrival]) -> dict[str, set[float]]:
    by_source: dict[str, set[float]] = defaultdict(set)
    for source, _, when in log:
        by_source[source].add(when)
    return by_source


def test_a_frame_reaches_every_receiver_at_one_instant_in_one_event() -> None:
    params = LinkParams(0.005, jitter=0.004)
    log, events = _run(params, per_frame=True)
    assert len(log) == 3 * 5 + 1
    assert events == 4
    instants = _instants(log)
    assert all(len(times) == 1 for times in instants.values())
    assert all(0.001 <= t <= 0.009 for times in instants.values() for t in times)
    assert len(set.union(*instants.values())) > 1  # each frame draws its own jitter
    # Receivers of one frame hear it in the order the router listed them.
    assert [r for s, r, _ in log if s == "a"] == list("bcdef")


def test_one_draw_per_receiver_without_it() -> None:
    log, events = _run(LinkParams(0.005, jitter=0.004), per_frame=False)
    assert len(log) == 3 * 5 + 1
    assert events == 16
    assert all(len(times) > 1 for s, times in _instants(log).items() if s != "d")


def test_without_jitter_both_models_are_the_same_run() -> None:
    params = LinkParams(0.005)
    assert _run(params, per_frame=True) == _run(params, per_frame=False)


def test_lossy_links_keep_their_draws_per_receiver() -> None:
    params = LinkParams(0.005, jitter=0.004, loss=0.2, duplicate=0.2)
    assert _run(params, per_frame=True) == _run(params, per_frame=False)


def test_a_link_set_apart_keeps_its_own_delay() -> None:
    log, _ = _run(LinkParams(0.005, jitter=0.004), per_frame=True, slow_link=True)
    (to_f,) = [when for s, r, when in log if (s, r) == ("a", "f")]
    others = {when for s, r, when in log if s == "a" and r != "f"}
    assert 0.046 <= to_f <= 0.054
    assert len(others) == 1


def test_nodes_agree_on_each_others_properties_with_one_draw_per_frame() -> None:
    net = SimulatedNetwork(seed=2, jitter=0.002, jitter_per_frame=True, beat_interval=1.0)
    nodes = {name: net.add_node(name) for name in ("a", "b", "c")}
    for number, node in enumerate(nodes.values()):
        node.update_node_property("n", number)
    net.run_for(2.0)
    for name, node in nodes.items():
        assert {peer: props["n"] for peer, props in node.view().items()} == {
            peer: number for number, peer in enumerate(nodes) if peer != name
        }


def test_a_receiver_that_restarts_while_a_frame_is_in_flight_loses_it() -> None:
    for per_frame in (True, False):
        loop = EventLoop()
        log: list[Arrival] = []
        net = MemoryNetwork(
            loop, random.Random(5), LinkParams(0.005, jitter=0.004), jitter_per_frame=per_frame
        )
        for name in "abc":
            net.attach(name, _Driver(name, log, loop))
        net.transmit("a", Broadcast(_FRAME, "property"))
        net.detach("b")
        net.attach("b", _Driver("b", log, loop))  # a new run of b: the old run's frame is lost
        net.transmit("c", Send("b", _FRAME, "property"))  # sent to the new run: it arrives
        loop.run_until(1.0)
        assert sorted((s, r) for s, r, _ in log) == [("a", "c"), ("c", "b")]
        assert net.stats().dropped["dead"] == 1
