"""Every operation of the space, one behaviour per test."""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from typing import Any

import pytest

from tuplespace import ANY, KINDS, TupleSpace, WatchOverflow


class FakeClock:
    """A clock the test moves by hand."""

    def __init__(self, now: float = 0.0) -> None:
        self.now = now

    def __call__(self) -> float:
        return self.now


Events = list[tuple[str, tuple[Any, ...]]]


@pytest.fixture
def space() -> TupleSpace:
    return TupleSpace()


def recorder() -> tuple[Events, Any]:
    events: Events = []

    def record(kind: str, tup: tuple[Any, ...]) -> None:
        events.append((kind, tup))

    return events, record


# -- out, rdp, inp ---------------------------------------------------------------


def test_inp_takes_and_rdp_only_reads(space: TupleSpace) -> None:
    space.out(("a", 1))
    assert space.rdp(("a", 1)) == ("a", 1)
    assert space.rdp(("a", 1)) == ("a", 1)
    assert space.inp(("a", 1)) == ("a", 1)
    assert space.inp(("a", 1)) is None
    assert space.rdp(("a", 1)) is None
    assert len(space) == 0


def test_no_match_is_none(space: TupleSpace) -> None:
    space.out(("a", 1))
    assert space.inp(("a", 2)) is None
    assert space.inp(("b", 1)) is None
    assert space.inp(("a", 1, 2)) is None  # an arity nothing has
    assert space.rdp((ANY, ANY, ANY)) is None


def test_oldest_match_wins(space: TupleSpace) -> None:
    for i in range(5):
        space.out(("job", i))
    assert [space.inp(("job", ANY)) for _ in range(5)] == [("job", i) for i in range(5)]


def test_oldest_match_wins_across_keys_for_a_formal_first_field(space: TupleSpace) -> None:
    space.out(("b", 1))
    space.out(("a", 2))
    space.out(("b", 3))
    assert space.inp((str, ANY)) == ("b", 1)
    assert space.inp((ANY, int)) == ("a", 2)
    assert space.inp((lambda v: v == "b", ANY)) == ("b", 3)


def test_every_template_field_kind(space: TupleSpace) -> None:
    space.out(("t", 1, "x", [1, 2], {"k": "v"}))
    assert space.rdp(("t", 1, "x", [1, 2], {"k": "v"})) is not None  # exact, unhashable
    assert space.rdp(("t", ANY, ANY, ANY, ANY)) is not None  # ANY
    assert space.rdp((str, int, str, list, dict)) is not None  # types
    assert space.rdp(("t", lambda v: v > 0, ANY, len, ANY)) is not None  # predicates
    assert space.rdp(("t", 2, ANY, ANY, ANY)) is None
    assert space.rdp(("t", str, ANY, ANY, ANY)) is None
    assert space.rdp(("t", lambda v: v > 1, ANY, ANY, ANY)) is None


def test_equal_values_match_across_types(space: TupleSpace) -> None:
    space.out((1, "one"))
    assert space.rdp((1.0, "one")) == (1, "one")
    assert space.rdp((True, ANY)) == (1, "one")


def test_unhashable_first_fields(space: TupleSpace) -> None:
    space.out(([1], "a"))
    space.out(({1}, "b"))
    assert space.rdp(([1], ANY)) == ([1], "a")
    assert space.rdp(([1], "a")) == ([1], "a")
    # A hashable template field can equal an unhashable stored one.
    assert space.rdp((frozenset({1}), ANY)) == ({1}, "b")
    assert space.inp((frozenset({1}), "b")) == ({1}, "b")
    assert space.inp(([1], "a")) == ([1], "a")
    assert len(space) == 0


def test_unhashable_and_keyed_tuples_keep_fifo_together(space: TupleSpace) -> None:
    space.out((frozenset({1}), 1))
    space.out(({1}, 2))
    space.out((frozenset({1}), 3))
    assert space.inp((frozenset({1}), ANY)) == (frozenset({1}), 1)
    assert space.inp((frozenset({1}), ANY)) == ({1}, 2)
    assert space.inp((frozenset({1}), int)) == (frozenset({1}), 3)


def test_the_empty_tuple(space: TupleSpace) -> None:
    space.out(())
    assert space.count(()) == 1
    assert space.inp(()) == ()
    assert space.inp(()) is None


def test_tuple_subclasses_are_tuples(space: TupleSpace) -> None:
    from collections import namedtuple

    point = namedtuple("point", "x y")
    space.out(point(1, 2))
    assert space.inp((1, 2)) == (1, 2)


def test_a_taken_tuple_in_the_middle_leaves_the_rest_in_order(space: TupleSpace) -> None:
    for i in range(100):
        space.out(("q", i))
    for i in range(1, 99, 2):
        assert space.inp(("q", i)) == ("q", i)
    assert [t[1] for t in space.rd_all(("q", ANY))] == [0, *range(2, 99, 2), 99]
    assert [t[1] for t in space.rd_all((ANY, ANY))] == [0, *range(2, 99, 2), 99]
    assert len(space) == 51


# -- rd_all, in_all, count, len --------------------------------------------------


def test_rd_all_in_all_count(space: TupleSpace) -> None:
    for i in range(4):
        space.out(("n", i))
    space.out(("other", 0))
    assert space.count(("n", ANY)) == 4
    assert space.count(("n", lambda v: v % 2 == 0)) == 2
    assert space.rd_all(("n", ANY)) == [("n", i) for i in range(4)]
    assert space.in_all(("n", lambda v: v % 2 == 1)) == [("n", 1), ("n", 3)]
    assert space.rd_all((ANY, ANY)) == [("n", 0), ("n", 2), ("other", 0)]
    assert space.in_all(("none", ANY)) == []
    assert space.count(("x", ANY, ANY)) == 0
    assert len(space) == 3


# -- bad use ---------------------------------------------------------------------


@pytest.mark.source_only("an argument of the wrong type")
@pytest.mark.parametrize("bad", [["a", 1], "a", None, {"a": 1}])
def test_out_of_a_non_tuple_is_a_type_error(space: TupleSpace, bad: object) -> None:
    with pytest.raises(TypeError, match="got " + repr(bad).replace("[", r"\[")):
        space.out(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [-1, -0.001, float("nan")])
def test_a_negative_lease_is_a_value_error(space: TupleSpace, bad: float) -> None:
    with pytest.raises(ValueError, match=f"got {bad!r}"):
        space.out(("a",), lease=bad)
    assert len(space) == 0


@pytest.mark.source_only("an argument of the wrong type")
@pytest.mark.parametrize("op", ["inp", "rdp", "rd_all", "in_all", "count"])
def test_a_non_tuple_template_is_a_type_error(space: TupleSpace, op: str) -> None:
    with pytest.raises(TypeError, match=r"\['a'\]"):
        getattr(space, op)(["a"])


def test_a_negative_timeout_is_a_value_error(space: TupleSpace) -> None:
    with pytest.raises(ValueError, match="got -1"):
        space.in_(("a",), timeout=-1)


def test_notify_rejects_unknown_kinds_and_non_callables(space: TupleSpace) -> None:
    with pytest.raises(ValueError, match="'rd'"):
        space.notify(("a",), lambda kind, tup: None, on=("out", "rd"))
    with pytest.raises(TypeError, match="42"):
        space.notify(("a",), 42)  # type: ignore[arg-type]
    assert frozenset({"out", "in", "expire"}) == KINDS


def test_a_raising_predicate_reaches_the_caller(space: TupleSpace) -> None:
    space.out(("a", 0))
    with pytest.raises(ZeroDivisionError):
        space.inp(("a", lambda v: 1 / v))
    assert space.inp(("a", 0)) == ("a", 0)  # the space still works


# -- leases ----------------------------------------------------------------------


def test_a_lease_ends_at_exactly_its_time() -> None:
    clock = FakeClock(10.0)
    space = TupleSpace(clock=clock)
    space.out(("lease", 1), lease=5.0)
    space.out(("forever", 1))
    assert space.next_expiry() == 15.0
    clock.now = 14.999
    assert space.rdp(("lease", ANY)) == ("lease", 1)
    assert space.expire() == 0
    clock.now = 15.0
    assert space.rdp(("lease", ANY)) is None  # never matches, even before expire()
    assert len(space) == 1
    assert space.next_expiry() is None
    assert space.rdp(("forever", 1)) == ("forever", 1)


def test_expire_drops_ended_leases_and_notifies() -> None:
    clock = FakeClock()
    space = TupleSpace(clock=clock)
    events, record = recorder()
    space.notify((ANY, ANY), record, on=("expire",))
    space.out(("a", 1), lease=1.0)
    space.out(("a", 2), lease=3.0)
    space.out(("a", 3), lease=2.0)
    assert space.next_expiry() == 1.0
    clock.now = 2.5
    assert space.expire() == 2
    assert events == [("expire", ("a", 1)), ("expire", ("a", 3))]
    assert space.next_expiry() == 3.0
    assert space.expire() == 0
    assert space.rd_all(("a", ANY)) == [("a", 2)]


def test_a_taken_leased_tuple_is_not_expired_later() -> None:
    clock = FakeClock()
    space = TupleSpace(clock=clock)
    space.out(("a", 1), lease=1.0)
    space.out(("a", 2), lease=2.0)
    assert space.inp(("a", 1)) == ("a", 1)
    assert space.next_expiry() == 2.0
    clock.now = 5.0
    assert space.expire() == 1


def test_a_zero_lease_reaches_a_waiter_but_is_never_stored() -> None:
    space = TupleSpace(clock=FakeClock())
    space.out(("z",), lease=0)
    assert len(space) == 0

    got: list[tuple[Any, ...]] = []
    reader = threading.Thread(target=lambda: got.append(space.in_(("z",), timeout=5)))
    reader.start()
    wait_for_waiters(space, 1)
    space.out(("z",), lease=0)
    reader.join(5)
    assert got == [("z",)]


def test_many_taken_leases_do_not_grow_the_heap() -> None:
    space = TupleSpace(clock=FakeClock())
    for i in range(1000):
        space.out(("a", i), lease=10.0)
        space.out(("keep", i), lease=10.0 + i)
        assert space.inp(("a", i)) is not None
    assert len(space._heap) <= 2 * 1000 + 64
    assert space.next_expiry() == 10.0


def test_the_real_clock_is_the_default() -> None:
    space = TupleSpace()
    space.out(("short",), lease=0.01)
    expiry = space.next_expiry()
    assert expiry is not None
    assert expiry <= time.monotonic() + 0.01
    time.sleep(0.02)
    assert space.rdp(("short",)) is None


# -- notify ----------------------------------------------------------------------


def test_notify_reports_out_and_in_of_matching_tuples(space: TupleSpace) -> None:
    events, record = recorder()
    handle = space.notify(("n", ANY), record)
    space.out(("n", 1))
    space.out(("other", 1))
    space.rdp(("n", 1))
    space.inp(("n", 1))
    space.out(("n", 2))
    space.in_all(("n", ANY))
    assert events == [("out", ("n", 1)), ("in", ("n", 1)), ("out", ("n", 2)), ("in", ("n", 2))]
    handle.cancel()
    handle.cancel()  # idempotent
    space.out(("n", 3))
    assert len(events) == 4
    assert "cancelled" in repr(handle)


def test_notify_on_one_kind(space: TupleSpace) -> None:
    events, record = recorder()
    with space.notify(("n", ANY), record, on="in"):
        space.out(("n", 1))
        space.inp(("n", 1))
    space.out(("n", 2))
    space.inp(("n", 2))
    assert events == [("in", ("n", 1))]


def test_a_raising_callback_is_logged_and_harmless(
    space: TupleSpace, caplog: pytest.LogCaptureFixture
) -> None:
    events, record = recorder()

    def boom(kind: str, tup: tuple[Any, ...]) -> None:
        raise RuntimeError("callback failed")

    space.notify(("n", ANY), boom)
    space.notify(("n", ANY), record)
    with caplog.at_level(logging.ERROR, logger="tuplespace"):
        space.out(("n", 1))
    assert events == [("out", ("n", 1))]
    assert space.inp(("n", 1)) == ("n", 1)
    assert any("callback failed" in r.exc_text for r in caplog.records if r.exc_text)
    assert all(r.name == "tuplespace" for r in caplog.records)


def test_a_raising_observer_template_is_logged(
    space: TupleSpace, caplog: pytest.LogCaptureFixture
) -> None:
    events, record = recorder()
    space.notify(("n", lambda v: 1 / v), record)
    with caplog.at_level(logging.ERROR, logger="tuplespace"):
        space.out(("n", 0))
    assert events == []
    assert caplog.records
    assert space.inp(("n", 0)) == ("n", 0)


def test_callbacks_run_outside_the_lock(space: TupleSpace) -> None:
    seen: list[tuple[Any, ...] | None] = []

    def reenter(kind: str, tup: tuple[Any, ...]) -> None:
        seen.append(space.inp(tup))  # would deadlock under the lock

    space.notify(("r", ANY), reenter, on="out")
    space.out(("r", 1))
    assert seen == [("r", 1)]
    assert len(space) == 0


# -- blocking, threads -----------------------------------------------------------


def wait_for_waiters(space: TupleSpace, n: int) -> None:
    deadline = time.monotonic() + 5
    while len(space._waiters) < n:
        assert time.monotonic() < deadline, "waiters never blocked"
        time.sleep(0.001)


def test_rd_and_in_return_at_once_when_a_tuple_exists(space: TupleSpace) -> None:
    space.out(("a", 1))
    assert space.rd(("a", ANY)) == ("a", 1)
    assert space.in_(("a", ANY), timeout=0) == ("a", 1)


def test_in_times_out(space: TupleSpace) -> None:
    start = time.monotonic()
    with pytest.raises(TimeoutError, match=r"\('a', ANY\)"):
        space.in_(("a", ANY), timeout=0.05)
    assert time.monotonic() - start >= 0.05
    assert not space._waiters
    with pytest.raises(TimeoutError):
        space.rd(("a", ANY), timeout=0)


def test_blocked_takers_are_served_in_arrival_order(space: TupleSpace) -> None:
    got: list[tuple[int, tuple[Any, ...]]] = []
    threads = []
    for i in range(5):
        thread = threading.Thread(target=lambda i=i: got.append((i, space.in_(("j", ANY), 5))))
        thread.start()
        wait_for_waiters(space, i + 1)
        threads.append(thread)
    for n in range(5):
        space.out(("j", n))
    for thread in threads:
        thread.join(5)
    assert sorted(got) == [(i, ("j", i)) for i in range(5)]


def test_a_written_tuple_wakes_readers_up_to_the_first_taker(space: TupleSpace) -> None:
    results: dict[str, tuple[Any, ...]] = {}

    def run(name: str, take: bool) -> None:
        op = space.in_ if take else space.rd
        results[name] = op(("w", ANY), 5)

    order = [("reader1", False), ("taker", True), ("reader2", False)]
    threads = []
    for i, (name, take) in enumerate(order):
        threads.append(threading.Thread(target=run, args=(name, take)))
        threads[-1].start()
        wait_for_waiters(space, i + 1)
    space.out(("w", 1))
    threads[0].join(5)
    threads[1].join(5)
    assert results == {"reader1": ("w", 1), "taker": ("w", 1)}
    assert len(space) == 0
    space.out(("w", 2))  # the later reader sees the next one; it stays stored
    threads[2].join(5)
    assert results["reader2"] == ("w", 2)
    assert space.rdp(("w", 2)) == ("w", 2)


def test_a_waiter_with_a_raising_template_does_not_break_out(
    space: TupleSpace, caplog: pytest.LogCaptureFixture
) -> None:
    outcome: list[BaseException] = []

    def wait() -> None:
        try:
            space.rd(("x", lambda v: 1 / v), 0.2)
        except TimeoutError as exc:  # the raising template never matches
            outcome.append(exc)

    thread = threading.Thread(target=wait)
    thread.start()
    wait_for_waiters(space, 1)
    with caplog.at_level(logging.ERROR, logger="tuplespace"):
        space.out(("x", 0))
    thread.join(5)
    assert caplog.records
    assert len(outcome) == 1
    assert space.inp(("x", 0)) == ("x", 0)


def test_notify_sees_a_tuple_taken_by_a_waiter(space: TupleSpace) -> None:
    events, record = recorder()
    space.notify(("n", ANY), record)
    thread = threading.Thread(target=lambda: space.in_(("n", ANY), 5))
    thread.start()
    wait_for_waiters(space, 1)
    space.out(("n", 1))
    thread.join(5)
    assert events == [("out", ("n", 1)), ("in", ("n", 1))]


def write(space: TupleSpace, tag: str, n: int) -> None:
    for i in range(n):
        space.out((tag, i))


# -- blocking, asyncio -----------------------------------------------------------


async def test_ain_and_ard(space: TupleSpace) -> None:
    space.out(("a", 1))
    assert await space.ard(("a", ANY)) == ("a", 1)
    assert await space.ain(("a", ANY)) == ("a", 1)
    task = asyncio.create_task(space.ain(("a", ANY)))
    await asyncio.sleep(0)
    space.out(("a", 2))
    assert await task == ("a", 2)


async def test_ain_times_out(space: TupleSpace) -> None:
    with pytest.raises(TimeoutError, match=r"within 0\.01 s"):
        await space.ain(("a", ANY), timeout=0.01)
    assert not space._waiters
    with pytest.raises(ValueError, match="got -1"):
        await space.ard(("a",), timeout=-1)


async def test_a_cancelled_ain_leaves_no_waiter(space: TupleSpace) -> None:
    task = asyncio.create_task(space.ain(("a", ANY)))
    await asyncio.sleep(0)
    task.cancel()
    with pytest.raises(asyncio.CancelledError):
        await task
    assert not space._waiters
    space.out(("a", 1))
    assert space.rdp(("a", 1)) == ("a", 1)


async def test_a_tuple_handed_to_a_cancelled_task_is_put_back(space: TupleSpace) -> None:
    task = asyncio.create_task(space.ain(("a", ANY)))
    await asyncio.sleep(0)
    space.out(("a", 1))  # resolves the task's future ...
    task.cancel()  # ... but the task is cancelled before it resumes
    with pytest.raises(asyncio.CancelledError):
        await task
    assert space.rdp(("a", 1)) == ("a", 1)


async def test_async_takers_are_served_in_arrival_order(space: TupleSpace) -> None:
    tasks = []
    for _ in range(10):
        tasks.append(asyncio.create_task(space.ain(("j", ANY))))
        await asyncio.sleep(0)
    for n in range(10):
        space.out(("j", n))
    assert await asyncio.gather(*tasks) == [("j", n) for n in range(10)]


async def test_threads_and_tasks_share_one_queue_of_takers(space: TupleSpace) -> None:
    got: list[tuple[Any, ...]] = []
    first = asyncio.create_task(space.ain(("j", ANY)))
    await asyncio.sleep(0)
    thread = threading.Thread(target=lambda: got.append(space.in_(("j", ANY), 5)))
    thread.start()
    await asyncio.to_thread(wait_for_waiters, space, 2)
    third = asyncio.create_task(space.ain(("j", ANY)))
    await asyncio.sleep(0)
    # Writes from another thread wake the tasks through call_soon_threadsafe.
    await asyncio.to_thread(write, space, "j", 3)
    assert await first == ("j", 0)
    await asyncio.to_thread(thread.join, 5)
    assert got == [("j", 1)]
    assert await third == ("j", 2)


async def test_a_task_wakes_a_thread(space: TupleSpace) -> None:
    waiter = asyncio.create_task(asyncio.to_thread(space.in_, ("t", ANY), 5))
    await asyncio.to_thread(wait_for_waiters, space, 1)
    space.out(("t", 1))
    assert await waiter == ("t", 1)


# -- watch -----------------------------------------------------------------------


async def test_watch_yields_matching_writes_from_now_on(space: TupleSpace) -> None:
    space.out(("w", 0))
    seen = []
    async with space.watch(("w", ANY)) as watch:
        space.out(("w", 1))
        space.out(("other", 1))
        space.out(("w", 2))
        async for tup in watch:
            seen.append(tup)
            if len(seen) == 2:
                break
    assert seen == [("w", 1), ("w", 2)]
    assert not space._observers


async def test_watch_waits_for_writes_from_threads(space: TupleSpace) -> None:
    watch = space.watch(("w", ANY))

    async def collect() -> list[tuple[Any, ...]]:
        return [tup async for tup in watch]

    task = asyncio.create_task(collect())
    await asyncio.to_thread(write, space, "w", 3)
    await asyncio.sleep(0.01)  # let the loop run the hand-overs the thread scheduled
    await watch.aclose()
    assert await task == [("w", 0), ("w", 1), ("w", 2)]


async def test_watch_overflow_is_an_error_after_the_buffered_tuples(space: TupleSpace) -> None:
    watch = space.watch(("w", ANY), maxsize=2)
    for n in range(3):
        space.out(("w", n))
    assert await anext(watch) == ("w", 0)
    assert await anext(watch) == ("w", 1)
    with pytest.raises(WatchOverflow, match="more than 2"):
        await anext(watch)
    assert not space._observers


async def test_a_dropped_watch_unregisters_itself(space: TupleSpace) -> None:
    watch = space.watch(("w", ANY))
    del watch
    space.out(("w", 1))
    assert not space._observers


def test_watch_needs_a_running_loop(space: TupleSpace) -> None:
    with pytest.raises(RuntimeError):
        space.watch(("w", ANY))


async def test_watch_rejects_a_tiny_buffer(space: TupleSpace) -> None:
    with pytest.raises(ValueError, match="got 0"):
        space.watch(("w", ANY), maxsize=0)


def test_repr(space: TupleSpace) -> None:
    space.out(("a",))
    assert repr(space) == "<TupleSpace with 1 tuples>"
