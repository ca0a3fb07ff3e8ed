"""The asyncio runner and the pump never lose a deadline.

asyncio runs a timer that falls due within one tick of its clock, so on a coarse clock
(15.6 ms on some platforms) a timer can run before the deadline it was set for. The
runner then ticks the machine, the tick fires nothing, and unless the runner re-arms,
the machine's deadline is left without a timer: heartbeats and retransmissions stop.

These tests drive the real ``AsyncioRunner`` on a real asyncio event loop whose clock is
virtual (the selector jumps the clock to the next timer instead of sleeping), so every
run is deterministic and instant, with the coarse clock tick set explicitly.
"""

from __future__ import annotations

import asyncio
import selectors
from collections.abc import Coroutine
from typing import Any

import pytest

from objectplaces import RoleActivator
from objectplaces.core.events import Broadcast, Output, Subscribe
from objectplaces.core.node import NodeConfig, NodeMachine
from objectplaces.runtime.aio import AsyncioRunner
from objectplaces.runtime.pump import Pump
from tuplespace import TupleSpace

COARSE_TICK = 0.015


class _JumpingSelector(selectors.DefaultSelector):
    """Polls without blocking, then moves the loop's virtual clock by the wait asked for."""

    def __init__(self, clock: VirtualClockLoop) -> None:
        super().__init__()
        self._clock = clock

    def select(self, timeout: float | None = None) -> list[Any]:
        events = super().select(0)
        if not events and timeout:
            self._clock.virtual_now += timeout
        elif not events and timeout is None:
            raise RuntimeError("the loop would wait forever: nothing is scheduled")
        return events


class VirtualClockLoop(asyncio.SelectorEventLoop):
    """A real asyncio loop on a virtual clock with a tick of ``granularity`` seconds."""

    def __init__(self, granularity: float) -> None:
        super().__init__(_JumpingSelector(self))
        self.virtual_now = 0.0
        # How asyncio models its clock's granularity: a timer due within one tick runs.
        self._clock_resolution = granularity

    def time(self) -> float:
        return self.virtual_now


def run_virtual(main: Coroutine[Any, Any, None], *, granularity: float = COARSE_TICK) -> None:
    loop = VirtualClockLoop(granularity)
    try:
        loop.run_until_complete(main)
    finally:
        loop.close()


def lone_node(
    transmit: Any, *, config: NodeConfig | None = None
) -> tuple[AsyncioRunner, RoleActivator]:
    """A node with no peers, driven by an ``AsyncioRunner`` on the running loop."""
    loop = asyncio.get_running_loop()
    machine = NodeMachine("a", now=loop.time(), config=config)
    runner = AsyncioRunner(machine, transmit)
    space = TupleSpace(clock=loop.time)
    return runner, RoleActivator(machine, clock=runner.now, wake=runner.wake, space=space)


def test_a_timer_that_the_loop_runs_early_still_fires() -> None:
    fired: list[float] = []

    async def main() -> None:
        runner, node = lone_node(lambda output: 0)
        node.call_later(0.5, lambda: fired.append(node.now()))
        # The application wakes the loop less than one clock tick before the deadline,
        # so the loop runs the runner's timer early, at 0.49.
        await asyncio.sleep(0.49)
        await asyncio.sleep(1.0)
        runner.close()

    run_virtual(main())
    assert fired == [0.5]


def test_heartbeats_keep_their_interval_on_a_coarse_clock() -> None:
    heartbeats: list[float] = []

    async def main() -> None:
        runner: AsyncioRunner | None = None

        def transmit(output: Output) -> int:
            if isinstance(output, Broadcast) and runner is not None:
                heartbeats.append(round(runner.now(), 6))
            return 0

        runner, node = lone_node(transmit, config=NodeConfig(property_interval=0.1))
        node.update_node_property("position", (1.0, 2.0))
        # Unrelated application work wakes the loop at times that never line up with the
        # heartbeat, so many of the runner's timers run up to one tick early.
        for _ in range(1000):
            await asyncio.sleep(0.0093)
        runner.close()

    run_virtual(main())
    assert heartbeats[0] == 0.0  # the update itself
    assert heartbeats[1:] == [round(0.1 * k, 6) for k in range(1, 94)]


def test_the_runner_clock_never_reads_earlier_than_a_deadline_it_ticked() -> None:
    readings: list[tuple[float, float]] = []

    async def main() -> None:
        loop = asyncio.get_running_loop()
        runner, node = lone_node(lambda output: 0)
        node.call_later(0.5, lambda: readings.append((loop.time(), node.now())))
        await asyncio.sleep(0.49)
        readings.append((loop.time(), node.now()))
        await asyncio.sleep(0.005)
        readings.append((loop.time(), node.now()))
        runner.close()

    run_virtual(main())
    # The timer ran at loop time 0.49, a tick early: the node's clock reads the deadline.
    assert readings == [(0.49, 0.5), (0.49, 0.5), (pytest.approx(0.495), 0.5)]


def test_a_closed_runner_fires_nothing() -> None:
    fired: list[float] = []

    async def main() -> None:
        runner, node = lone_node(lambda output: 0)
        node.call_later(0.5, lambda: fired.append(node.now()))
        await asyncio.sleep(0.1)
        runner.close()
        await asyncio.sleep(1.0)

    run_virtual(main())
    assert fired == []


def test_a_failing_transport_costs_one_output_not_the_drain_or_the_timer() -> None:
    machine = NodeMachine("a", now=0.0, config=NodeConfig(property_interval=1.0))
    transmitted: list[Output] = []
    scheduled: list[float | None] = []
    observed: list[tuple[str, str, Any]] = []

    def transmit(output: Output) -> int:
        if isinstance(output, Subscribe):
            raise ConnectionError("link down")
        transmitted.append(output)
        return 1

    pump = Pump(machine, transmit, scheduled.append)
    node = RoleActivator(machine, clock=lambda: 0.0, wake=pump.drain, space=TupleSpace())
    node.register_node_property_observer(lambda *change: observed.append(change))
    node.update_node_property("status", "idle")  # drains: Subscribe fails, Broadcast goes

    assert [type(output).__name__ for output in transmitted] == ["Broadcast"]
    assert observed == [("a", "status", "idle")]
    assert scheduled == [1.0]
