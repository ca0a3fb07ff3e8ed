"""Benchmark the tuplespace against a naive list-scan space, in one run.

Workloads:
- out+inp pairs per second with 10k unrelated tuples present (all-exact template, and a
  tag with ``ANY`` fields);
- ``rd`` with a concrete first field among 100k tuples (ops per second);
- wake-up latency of a blocked ``in_``, thread -> thread and task -> task (p50/p99).

Run: ``.venv/bin/python bench/tuplespace.py``; it prints the figures and writes the
"tuplespace" section of BENCHMARKS.md.
"""

from __future__ import annotations

import asyncio
import random
import statistics
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Protocol

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from rich.progress import Progress

from bench.report import markdown_table, publish
from tuplespace import ANY, TupleSpace, compile_template

__all__ = ["NaiveSpace", "main"]

Tup = tuple[Any, ...]

UNRELATED = 10_000
PAIRS = 200_000
NAIVE_PAIRS = 400
RD_TUPLES = 100_000
RD_OPS = 200_000
NAIVE_RD_OPS = 60
WAKEUPS = 2_000
REPEATS = 5
PAUSE = 0.0005  # between wake-up rounds, so the taker is surely blocked


class Space(Protocol):
    def out(self, tup: Tup) -> None: ...
    def inp(self, tmpl: Tup) -> Tup | None: ...
    def rdp(self, tmpl: Tup) -> Tup | None: ...
    def in_(self, tmpl: Tup) -> Tup: ...
    async def ain(self, tmpl: Tup) -> Tup: ...


class NaiveSpace:
    """The baseline: one list scanned oldest first, one Condition, the same matcher.

    Blocked tasks are woken on every write and scan again.
    """

    def __init__(self) -> None:
        self._items: list[Tup] = []
        self._cond = threading.Condition()
        self._futures: list[tuple[asyncio.AbstractEventLoop, asyncio.Future[None]]] = []

    def out(self, tup: Tup) -> None:
        """Append ``tup`` and wake every waiter."""
        with self._cond:
            self._items.append(tup)
            self._cond.notify_all()
            futures, self._futures = self._futures, []
        for loop, future in futures:
            loop.call_soon_threadsafe(_resolve, future)

    def _scan(self, tmpl: Tup, take: bool) -> Tup | None:
        t = compile_template(tmpl)
        n = t.arity
        if t.exact:
            for i, tup in enumerate(self._items):
                if tup == tmpl:
                    return self._items.pop(i) if take else tup
            return None
        for i, tup in enumerate(self._items):
            if len(tup) == n and t.matches(tup):
                return self._items.pop(i) if take else tup
        return None

    def inp(self, tmpl: Tup) -> Tup | None:
        """Take the oldest match or return None."""
        with self._cond:
            return self._scan(tmpl, True)

    def rdp(self, tmpl: Tup) -> Tup | None:
        """Read the oldest match or return None."""
        with self._cond:
            return self._scan(tmpl, False)

    def in_(self, tmpl: Tup) -> Tup:
        """Take the oldest match, blocking the thread."""
        with self._cond:
            while (tup := self._scan(tmpl, True)) is None:
                self._cond.wait()
            return tup

    async def ain(self, tmpl: Tup) -> Tup:
        """Take the oldest match, waiting asynchronously."""
        loop = asyncio.get_running_loop()
        while True:
            with self._cond:
                tup = self._scan(tmpl, True)
                if tup is not None:
                    return tup
                future: asyncio.Future[None] = loop.create_future()
                self._futures.append((loop, future))
            await future


def _resolve(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


# -- workloads --------------------------------------------------------------------


def fill_unrelated(space: Space) -> None:
    for i in range(UNRELATED):
        space.out((f"other-{i % 100}", i, "x"))


def pairs_per_s(space: Space, n: int, tag_template: bool) -> float:
    """Best of REPEATS: out then inp of the same tuple, n times."""
    tups = [("job", i, "payload") for i in range(n)]
    tmpls = [("job", ANY, ANY)] * n if tag_template else tups
    best = float("inf")
    out, inp = space.out, space.inp
    for _ in range(REPEATS):
        start = time.perf_counter()
        for tup, tmpl in zip(tups, tmpls, strict=True):
            out(tup)
            inp(tmpl)
        best = min(best, time.perf_counter() - start)
    return n / best


def rd_per_s(space: Space, n: int) -> float:
    """Best of REPEATS: rdp of a random key among RD_TUPLES distinct first fields."""
    rng = random.Random(1)
    tmpls = [(f"k{rng.randrange(RD_TUPLES)}", ANY, ANY) for _ in range(n)]
    rdp = space.rdp
    best = float("inf")
    for _ in range(REPEATS):
        start = time.perf_counter()
        for tmpl in tmpls:
            if rdp(tmpl) is None:
                raise AssertionError(f"{tmpl!r} not found")
        best = min(best, time.perf_counter() - start)
    return n / best


def fill_keys(space: Space) -> None:
    for i in range(RD_TUPLES):
        space.out((f"k{i}", i, "v"))


def thread_wakeups(space: Space, n: int) -> list[float]:
    """Microseconds from ``out`` in one thread to ``in_`` returning in another."""
    latencies: list[float] = []

    def taker() -> None:
        for _ in range(n):
            tup = space.in_(("ping", ANY))
            latencies.append((time.perf_counter_ns() - tup[1]) / 1000)
            space.out(("pong",))

    thread = threading.Thread(target=taker)
    thread.start()
    for _ in range(n):
        time.sleep(PAUSE)
        space.out(("ping", time.perf_counter_ns()))
        space.in_(("pong",))
    thread.join()
    return latencies


def task_wakeups(space: Space, n: int) -> list[float]:
    """Microseconds from ``out`` in one task to ``ain`` returning in another."""
    latencies: list[float] = []

    async def taker() -> None:
        for _ in range(n):
            tup = await space.ain(("ping", ANY))
            latencies.append((time.perf_counter_ns() - tup[1]) / 1000)
            space.out(("pong",))

    async def run() -> None:
        async with asyncio.TaskGroup() as group:
            group.create_task(taker())
            for _ in range(n):
                await asyncio.sleep(PAUSE)
                space.out(("ping", time.perf_counter_ns()))
                await space.ain(("pong",))

    asyncio.run(run())
    return latencies


def percentiles(latencies: list[float]) -> tuple[float, float]:
    cuts = statistics.quantiles(latencies, n=100, method="inclusive")
    return cuts[49], cuts[98]


# -- report -----------------------------------------------------------------------


@contextmanager
def step(progress: Progress, label: str) -> Iterator[None]:
    task = progress.add_task(label, total=1)
    yield
    progress.update(task, completed=1)


def fmt_rate(rate: float) -> str:
    return f"{rate:,.0f}"


def main() -> None:
    """Measure every workload on both spaces, print and record the figures."""
    results: dict[str, Any] = {}
    jobs: list[tuple[str, Callable[[], Any]]] = []

    def pairs(kind: Callable[[], Space], n: int, tag: bool) -> float:
        space = kind()
        fill_unrelated(space)
        return pairs_per_s(space, n, tag)

    def rds(kind: Callable[[], Space], n: int) -> float:
        space = kind()
        fill_keys(space)
        return rd_per_s(space, n)

    jobs += [
        ("pairs exact", lambda: pairs(TupleSpace, PAIRS, False)),
        ("pairs exact naive", lambda: pairs(NaiveSpace, NAIVE_PAIRS, False)),
        ("pairs tag", lambda: pairs(TupleSpace, PAIRS, True)),
        ("pairs tag naive", lambda: pairs(NaiveSpace, NAIVE_PAIRS, True)),
        ("rd", lambda: rds(TupleSpace, RD_OPS)),
        ("rd naive", lambda: rds(NaiveSpace, NAIVE_RD_OPS)),
        ("thread wake", lambda: percentiles(thread_wakeups(TupleSpace(), WAKEUPS))),
        ("thread wake naive", lambda: percentiles(thread_wakeups(NaiveSpace(), WAKEUPS))),
        ("task wake", lambda: percentiles(task_wakeups(TupleSpace(), WAKEUPS))),
        ("task wake naive", lambda: percentiles(task_wakeups(NaiveSpace(), WAKEUPS))),
    ]
    with Progress(transient=True) as progress:
        for label, job in jobs:
            with step(progress, label):
                results[label] = job()

    def rate_row(label: str, key: str) -> list[str]:
        ours, naive = results[key], results[f"{key} naive"]
        return [label, fmt_rate(ours), fmt_rate(naive), f"{ours / naive:,.0f}x"]

    def wake_row(label: str, key: str) -> list[str]:
        (p50, p99), (n50, n99) = results[key], results[f"{key} naive"]
        return [label, f"{p50:.0f} / {p99:.0f}", f"{n50:.0f} / {n99:.0f}", f"{n50 / p50:.1f}x"]

    table = markdown_table(
        ["workload", "TupleSpace", "naive list scan", "ratio"],
        [
            rate_row(
                f"out+inp pairs/s, {UNRELATED:,} unrelated tuples, exact template", "pairs exact"
            ),
            rate_row(
                f'out+inp pairs/s, {UNRELATED:,} unrelated tuples, ("job", ANY, ANY)', "pairs tag"
            ),
            rate_row(f"rd ops/s, concrete first field, {RD_TUPLES:,} tuples", "rd"),
            wake_row("blocked in_ wake-up thread -> thread, p50 / p99 us", "thread wake"),
            wake_row("blocked ain wake-up task -> task, p50 / p99 us", "task wake"),
        ],
    )
    goals = markdown_table(
        ["goal", "measured", "met"],
        [
            [
                ">= 500k out+inp pairs/s with 10k unrelated tuples (exact template)",
                fmt_rate(results["pairs exact"]),
                "yes" if results["pairs exact"] >= 500_000 else "no",
            ],
            [
                ">= 100x the naive space at 100k tuples (rd)",
                f"{results['rd'] / results['rd naive']:,.0f}x",
                "yes" if results["rd"] >= 100 * results["rd naive"] else "no",
            ],
            [
                "wake-up p50 < 100 us (thread -> thread)",
                f"{results['thread wake'][0]:.0f} us",
                "yes" if results["thread wake"][0] < 100 else "no",
            ],
            [
                "wake-up p50 < 100 us (task -> task)",
                f"{results['task wake'][0]:.0f} us",
                "yes" if results["task wake"][0] < 100 else "no",
            ],
        ],
    )
    body = (
        f"{table}\n\n{goals}\n\n"
        f"Rates are the best of {REPEATS} runs ({PAIRS:,} pairs, {RD_OPS:,} reads; the naive "
        f"space {NAIVE_PAIRS:,} pairs, {NAIVE_RD_OPS:,} reads). Wake-up latency: "
        f"{WAKEUPS:,} rounds, the writer pausing {PAUSE * 1e6:.0f} us before each write so "
        "the taker is blocked; the time runs from just before `out` to the taker holding "
        "the tuple. The naive space scans one list with the same matcher and wakes every "
        "waiter on every write."
    )
    publish("tuplespace", "tuplespace", body, ".venv/bin/python bench/tuplespace.py")


if __name__ == "__main__":
    main()
