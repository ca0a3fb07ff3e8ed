"""The puppet node process itself: it stops by itself, serves one node after another
with nothing left of the last, and reports a failed command as a failure."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from objectplaces import groups
from tests.conformance.proxy import PuppetNode, PuppetPool, poll
from tests.credentials import TEST_SECRET

pytestmark = pytest.mark.processes
SECRET = TEST_SECRET


@pytest.fixture
def pool() -> Iterator[PuppetPool]:
    pool = PuppetPool(spares=0)
    try:
        yield pool
    finally:
        pool.close()


async def started(pool: PuppetPool, node_id: str) -> PuppetNode:
    node = pool.take()
    node.start_node(node_id, "websocket", SECRET, property_interval=0.2)
    await poll([node], lambda: node.address is not None, within=30)
    return node


async def test_the_end_of_its_input_lets_the_node_leave_and_ends_the_process(
    pool: PuppetPool,
) -> None:
    node = await started(pool, "x")
    node.process.end_input()  # what the test process's death looks like to the puppet
    assert node.process.proc.wait(timeout=10) == 0
    node.drain()
    assert node.closed


async def test_a_process_used_again_starts_a_node_with_nothing_of_the_last(
    pool: PuppetPool,
) -> None:
    first = await started(pool, "x")
    first.serve("ticker")
    first.update_node_property("position", (0.0, 0.0))
    await first.start_interaction(groups.within(5.0), "ticker")
    await poll([first], lambda: first.state_counts().get("sessions") == 1, within=10)
    first.process.send(cmd="leave")
    await poll([first], lambda: first.closed, within=10)
    pool.give_back(first)
    second = await started(pool, "y")
    assert second.process is first.process
    # A report of the last node's session would fail the mirror (no such session here).
    await poll([second], lambda: bool(second.state_counts()), within=10)
    assert second.state_counts()["sessions"] == 0


async def test_a_failed_command_fails_the_scenario_with_the_reason(pool: PuppetPool) -> None:
    node = await started(pool, "x")
    node.process.send(cmd="stop", session="no-such-session")
    with pytest.raises(AssertionError, match="LocalProtocolError"):
        await poll([node], lambda: False, within=10)
