"""The same role code and the same expectations on the simulated network, the mesh and Zenoh."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Callable
from typing import Any

import msgpack
import pytest

from objectplaces import Initiator, Participant, groups
from objectplaces.roles import InitiatorRef, ParticipantRef
from tests.conformance.harness import Harness, MeshHarness, SimHarness, ZenohHarness

HARNESSES: dict[str, Callable[[], Harness]] = {
    "sim": SimHarness,
    "mesh": MeshHarness,
    "zenoh-peer": ZenohHarness,
    "zenoh-client": lambda: ZenohHarness(via_router=True),
}


@pytest.fixture(params=list(HARNESSES))
async def net(request: pytest.FixtureRequest) -> AsyncIterator[Harness]:
    harness = HARNESSES[request.param]()
    try:
        yield harness
    finally:
        await harness.close()


class Recorder(Initiator):
    """Logs every callback with the session it was told about."""

    def __init__(self) -> None:
        self.log: list[tuple[str, str, str, Any]] = []

    def in_group(self, p: ParticipantRef) -> None:
        self.log.append(("in", p.node_id, p.session_id, None))
        self.send(p, "welcome")

    def out_group(self, p: ParticipantRef) -> None:
        self.log.append(("out", p.node_id, p.session_id, None))

    def receive(self, p: ParticipantRef, message: Any) -> None:
        self.log.append(("rx", p.node_id, p.session_id, message))

    def members_now(self) -> set[str]:
        return {p.node_id for p in self.members}

    def heard(self, node: str, what: str) -> bool:
        return any(e[0] == "rx" and e[1] == node and what in str(e[3]) for e in self.log)


class Ticker(Participant):
    """Says hello, ticks every 20 ms, echoes; logs its activation."""

    def __init__(self) -> None:
        self.log: list[str] = []
        self.ticks = 0

    def in_group_of(self, initiator: InitiatorRef) -> None:
        self.log.append(f"in {initiator.session_id}")
        self.send(f"hello from {self.node_id}")
        self.call_later(0.02, self.tick)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        self.log.append(f"out {initiator.session_id}")

    def receive(self, message: Any) -> None:
        self.send(f"echo {message}")

    def tick(self) -> None:
        self.ticks += 1
        self.send(f"tick {self.ticks}")
        self.call_later(0.02, self.tick)


def only_members_spoke(recorder: Recorder, sid: str) -> None:
    members: set[str] = set()
    for kind, node, session, message in recorder.log:
        assert session == sid, f"event of another session: {(kind, node, session, message)}"
        if kind == "in":
            members.add(node)
        elif kind == "out":
            members.discard(node)
        else:
            assert node in members, f"message from non-member {node}: {message!r}"


async def test_start_every_node_sees_the_others(net: Harness) -> None:
    nodes = [await net.add(f"n{i}") for i in range(3)]
    for i, node in enumerate(nodes):
        node.update_node_property("position", (float(i), 0.0))
    await net.until(
        lambda: all(
            {n: p.get("position") for n, p in node.view().items()}
            == {f"n{j}": (float(j), 0.0) for j in range(3) if nodes[j] is not node}
            for node in nodes
        )
    )


async def test_join_a_newcomer_in_range_enters_the_session(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    recorder = Recorder()
    session = a.start_interaction(recorder, groups.within(5.0), "ticker")
    tickers: dict[str, Ticker] = {}

    def factory(name: str) -> Any:
        return lambda: tickers.setdefault(name, Ticker())

    for name, x in (("near", 3.0), ("far", 50.0)):
        node = await net.add(name)
        node.set_participant_factory("ticker", factory(name))
        node.update_node_property("position", (x, 0.0))
    await net.until(lambda: recorder.heard("near", "echo") and recorder.heard("near", "tick"))
    assert recorder.members_now() == {"near"}
    assert "far" not in tickers
    only_members_spoke(recorder, session.session_id)


async def test_leave_a_member_that_leaves_is_removed(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    b = await net.add("b")
    ticker = Ticker()
    b.set_participant_factory("ticker", lambda: ticker)
    b.update_node_property("position", (1.0, 0.0))
    recorder = Recorder()
    session = a.start_interaction(recorder, groups.within(5.0), "ticker")
    await net.until(lambda: recorder.members_now() == {"b"})
    await net.leave("b")
    await net.until(lambda: ("out", "b", session.session_id, None) in recorder.log)
    assert ticker.log == [f"in {session.session_id}", f"out {session.session_id}"]
    assert "b" not in a.view()
    only_members_spoke(recorder, session.session_id)


async def test_stop_deactivates_every_participant_and_leaves_no_state(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    tickers: list[Ticker] = []

    def make_ticker() -> Ticker:
        tickers.append(Ticker())
        return tickers[-1]

    others = []
    for i in range(3):
        node = await net.add(f"p{i}")
        node.set_participant_factory("ticker", make_ticker)
        node.update_node_property("position", (1.0 + i, 0.0))
        others.append(node)
    recorder = Recorder()
    session = a.start_interaction(recorder, groups.within(5.0), "ticker")
    await net.until(lambda: recorder.members_now() == {"p0", "p1", "p2"})
    a.stop_interaction(session)
    live = ("sessions", "members", "closing_channels", "participations", "role_timers")

    def clean() -> bool:
        return all(all(node.machine.state_counts()[k] == 0 for k in live) for node in [a, *others])

    await net.until(lambda: clean() and all(t.log[-1].startswith("out") for t in tickers))
    assert len(tickers) == 3


async def test_guarantee_1_initiator_hears_only_its_current_members(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    c = await net.add("c")
    c.update_node_property("position", (100.0, 0.0))
    movers = []
    for i in range(2):
        node = await net.add(f"m{i}")
        node.set_participant_factory("ticker", Ticker)
        node.update_node_property("position", (1.0 + i, 0.0))
        movers.append(node)
    ours, theirs = Recorder(), Recorder()
    session = a.start_interaction(ours, groups.within(5.0), "ticker")
    other = c.start_interaction(theirs, groups.within(500.0), "ticker")
    await net.until(lambda: ours.heard("m0", "tick 3") and theirs.heard("m1", "tick 3"))
    movers[0].update_node_property("position", (60.0, 0.0))  # m0 leaves a's group
    await net.until(lambda: ("out", "m0", session.session_id, None) in ours.log)
    mark = len(ours.log)
    await net.until(lambda: ours.heard("m1", "tick 10") and theirs.heard("m0", "tick 10"))
    assert not any(e[1] == "m0" for e in ours.log[mark:])
    only_members_spoke(ours, session.session_id)
    only_members_spoke(theirs, other.session_id)


async def test_scoped_dissemination_hears_its_cells_and_forgets_the_departed(net: Harness) -> None:
    scoped = await net.add("scoped", interest_radius=10.0)
    scoped.update_node_property("position", (5.0, 5.0))
    near = await net.add("near")
    near.update_node_property("position", (8.0, 5.0))
    mover = await net.add("mover")
    mover.update_node_property("position", (500.0, 500.0))
    await net.until(lambda: "mover" in near.view() and "near" in scoped.view())
    assert "mover" not in scoped.view()
    mover.update_node_property("position", (6.0, 6.0))
    await net.until(lambda: scoped.view().get("mover", {}).get("position") == (6.0, 6.0))
    mover.update_node_property("position", (500.0, 500.0))
    await net.until(lambda: "mover" not in scoped.view())


async def test_hostile_frames_cost_the_sender_never_the_node(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    recorder = Recorder()
    session = a.start_interaction(recorder, groups.within(5.0), "ticker")  # indexes positions
    b = await net.add("b")
    b.set_participant_factory("ticker", Ticker)
    b.update_node_property("position", (1.0, 0.0))
    await net.until(lambda: recorder.members_now() == {"b"})
    unusable = [["x", "y"], [math.nan, 0], [math.inf, -math.inf], [None, 1]]
    await net.hostile("a", [msgpack.packb([1, 1, {"position": p}]) for p in unusable])
    b.update_node_property("position", (2.0, 0.0))
    await net.until(lambda: a.view()["b"]["position"] == (2.0, 0.0))
    mark = len(recorder.log)
    await net.until(lambda: any(e[0] == "rx" for e in recorder.log[mark:]))
    assert recorder.members_now() == {"b"}
    only_members_spoke(recorder, session.session_id)
