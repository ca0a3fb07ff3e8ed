"""The same role code and the same expectations on the simulated network, and on mesh and
Zenoh nodes that each run in a process of their own."""

from __future__ import annotations

import math
from collections.abc import AsyncIterator, Callable, Iterator

import msgpack
import pytest

from objectplaces import groups
from tests.conformance.harness import (
    FAILURE_TIMEOUT,
    Harness,
    MeshProcesses,
    SimHarness,
    ZenohProcesses,
)
from tests.conformance.proxy import PuppetPool
from tests.conformance.roles import RecorderLog

HARNESSES: dict[str, Callable[[PuppetPool], Harness]] = {
    "sim": SimHarness,
    "mesh": MeshProcesses,
    "zenoh-peer": ZenohProcesses,
    "zenoh-client": lambda pool: ZenohProcesses(pool, via_router=True),
}
PROCESSES = pytest.mark.processes


@pytest.fixture(scope="module")
def puppets() -> Iterator[PuppetPool]:
    """Node processes started ahead of need, shared by the scenarios of this module."""
    pool = PuppetPool()
    try:
        yield pool
    finally:
        pool.close()


@pytest.fixture(
    params=[pytest.param(name, marks=[] if name == "sim" else [PROCESSES]) for name in HARNESSES]
)
async def net(request: pytest.FixtureRequest) -> AsyncIterator[Harness]:
    pool = None if request.param == "sim" else request.getfixturevalue("puppets")
    harness = HARNESSES[request.param](pool)  # type: ignore[arg-type]
    try:
        yield harness
    finally:
        await harness.close()


def only_members_spoke(recorder: RecorderLog, sid: str) -> None:
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
    recorder = await a.start_interaction(groups.within(5.0), "ticker")
    tickers = {}
    for name, x in (("near", 3.0), ("far", 50.0)):
        node = await net.add(name)
        tickers[name] = node.serve("ticker")
        node.update_node_property("position", (x, 0.0))
    await net.until(lambda: recorder.heard("near", "echo") and recorder.heard("near", "tick"))
    assert recorder.members_now() == {"near"}
    assert not tickers["far"]
    only_members_spoke(recorder, recorder.session_id)


async def test_leave_a_member_that_leaves_is_removed(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    b = await net.add("b")
    tickers = b.serve("ticker")
    b.update_node_property("position", (1.0, 0.0))
    recorder = await a.start_interaction(groups.within(5.0), "ticker")
    sid = recorder.session_id
    await net.until(lambda: recorder.members_now() == {"b"})
    await net.leave("b")
    await net.until(lambda: ("out", "b", sid, None) in recorder.log)
    assert [t.log for t in tickers] == [[f"in {sid}", f"out {sid}"]]
    assert "b" not in a.view()
    only_members_spoke(recorder, sid)


async def test_stop_deactivates_every_participant_and_leaves_no_state(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    others, tickers = [], []
    for i in range(3):
        node = await net.add(f"p{i}")
        tickers.append(node.serve("ticker"))
        node.update_node_property("position", (1.0 + i, 0.0))
        others.append(node)
    recorder = await a.start_interaction(groups.within(5.0), "ticker")
    await net.until(lambda: recorder.members_now() == {"p0", "p1", "p2"})
    a.stop_interaction(recorder)
    live = ("sessions", "members", "closing_channels", "participations", "role_timers")

    def clean() -> bool:
        return all(all(node.state_counts()[k] == 0 for k in live) for node in [a, *others])

    def all_out() -> bool:
        # Each participant's activation and deactivation are reported: a puppet's report
        # may come after its peers' (a loaded machine), and its counts were zero before.
        return all(made and made[-1].log[-1].startswith("out") for made in tickers)

    await net.until(lambda: clean() and all_out())
    assert [len(made) for made in tickers] == [1, 1, 1]


async def test_guarantee_1_initiator_hears_only_its_current_members(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    c = await net.add("c")
    c.update_node_property("position", (100.0, 0.0))
    movers = []
    for i in range(2):
        node = await net.add(f"m{i}")
        node.serve("ticker")
        node.update_node_property("position", (1.0 + i, 0.0))
        movers.append(node)
    ours = await a.start_interaction(groups.within(5.0), "ticker")
    theirs = await c.start_interaction(groups.within(500.0), "ticker")
    await net.until(lambda: ours.heard("m0", "tick 3") and theirs.heard("m1", "tick 3"))
    movers[0].update_node_property("position", (60.0, 0.0))  # m0 leaves a's group
    await net.until(lambda: ("out", "m0", ours.session_id, None) in ours.log)
    mark = len(ours.log)
    await net.until(lambda: ours.heard("m1", "tick 10") and theirs.heard("m0", "tick 10"))
    assert not any(e[1] == "m0" for e in ours.log[mark:])
    only_members_spoke(ours, ours.session_id)
    only_members_spoke(theirs, theirs.session_id)


async def test_kill_a_crashed_node_leaves_every_group_it_was_in(net: Harness) -> None:
    a = await net.add("a")
    a.update_node_property("position", (0.0, 0.0))
    c = await net.add("c")
    c.update_node_property("position", (4.0, 0.0))
    survivor, doomed = await net.add("survivor"), await net.add("doomed")
    for node, x in ((survivor, 2.5), (doomed, 2.0)):
        node.serve("ticker")
        node.update_node_property("position", (x, 0.0))
    ours = await a.start_interaction(groups.within(5.0), "ticker")
    theirs = await c.start_interaction(groups.within(5.0), "ticker")
    both = {"survivor", "doomed"}
    await net.until(lambda: ours.members_now() == both and theirs.members_now() == both)
    await net.until(lambda: ours.heard("doomed", "tick") and theirs.heard("doomed", "tick"))
    await net.kill("doomed")  # no goodbye: failure detection (or Zenoh liveliness) notices
    await net.until(
        lambda: (
            ("out", "doomed", ours.session_id, None) in ours.log
            and ("out", "doomed", theirs.session_id, None) in theirs.log
        ),
        within=FAILURE_TIMEOUT + 5.0,
    )
    await net.until(lambda: "doomed" not in a.view() and "doomed" not in c.view())
    mark = len(ours.log), len(theirs.log)
    await net.until(
        lambda: (
            any(e[1] == "survivor" for e in ours.log[mark[0] :])
            and any(e[1] == "survivor" for e in theirs.log[mark[1] :])
        )
    )
    assert ours.members_now() == theirs.members_now() == {"survivor"}
    only_members_spoke(ours, ours.session_id)
    only_members_spoke(theirs, theirs.session_id)


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
    recorder = await a.start_interaction(groups.within(5.0), "ticker")  # indexes positions
    b = await net.add("b")
    b.serve("ticker")
    b.update_node_property("position", (1.0, 0.0))
    await net.until(lambda: recorder.members_now() == {"b"})
    unusable = [["x", "y"], [math.nan, 0], [math.inf, -math.inf], [None, 1]]
    await net.hostile("a", [msgpack.packb([1, 1, {"position": p}]) for p in unusable])
    b.update_node_property("position", (2.0, 0.0))
    await net.until(lambda: a.view()["b"]["position"] == (2.0, 0.0))
    mark = len(recorder.log)
    await net.until(lambda: any(e[0] == "rx" for e in recorder.log[mark:]))
    assert recorder.members_now() == {"b"}
    only_members_spoke(recorder, recorder.session_id)
