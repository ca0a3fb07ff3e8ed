"""A virtual clock and an event queue: simulated time only moves when events run.

Events run in the order of ``(time, scheduling order)``. The queue is a binary heap.
A frame sent to many nodes schedules one arrival per recipient, and a large network's
heartbeats leave together: 200 nodes put 40,000 arrivals in the heap at one instant,
and each push and pop then walks a deep heap that no longer fits the cache.
``call_each`` therefore keeps such a batch outside the heap, sorted, as one *run*, and
only the run's next arrival sits in the heap: a k-way merge of the runs and the single
events. The order is the same as with every arrival in the heap (the merge yields the
smallest ``(time, scheduling order)`` first, and each arrival keeps the place in the
scheduling order it was given when scheduled); only the heap is smaller.
"""

from __future__ import annotations

import contextlib
import gc
import heapq
import itertools
from collections.abc import Callable, Iterable, Iterator
from typing import Any

__all__ = ["EventLoop"]


def _run_marker() -> None:
    """Stands in a heap entry for a run: its ``args`` is the run ``[next index, fn, arrivals]``."""


_RUN: Callable[..., Any] = _run_marker

GC_ALLOCATIONS = 100_000
"""Allocations between two young-generation collections while events run (Python's
default is 700). A simulation allocates a tuple per arrival and keeps a large state
alive; at the default, the collector's passes over that state cost a third of a
200-node run. Cycles wait a little longer to be freed; nothing else changes."""


@contextlib.contextmanager
def _collections_spaced() -> Iterator[None]:
    """Space the collector's passes to ``GC_ALLOCATIONS`` for the block, then restore."""
    young, *older = gc.get_threshold()
    if not young or young >= GC_ALLOCATIONS:  # off, or set higher by the application
        yield
        return
    gc.set_threshold(GC_ALLOCATIONS, *older)
    try:
        yield
    finally:
        gc.set_threshold(young, *older)


class EventLoop:
    """Runs scheduled calls in time order; ties keep their scheduling order."""

    def __init__(self, start: float = 0.0) -> None:
        self.now = start
        self._queue: list[tuple[float, int, Callable[..., Any], Any]] = []
        self._seq = itertools.count()
        self.events_run = 0

    def __len__(self) -> int:
        """How many entries the heap holds (a run of arrivals counts once)."""
        return len(self._queue)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` at virtual time ``when`` (now if it lies in the past)."""
        now = self.now
        heapq.heappush(self._queue, (when if when > now else now, next(self._seq), fn, args))

    def call_each(
        self, fn: Callable[..., Any], calls: Iterable[tuple[float, tuple[Any, ...]]]
    ) -> None:
        """``call_at(when, fn, *args)`` for each ``(when, args)``, in that order.

        The simulated network schedules one arrival per recipient of a frame this way;
        the batch waits outside the heap, sorted, and only its next call sits in it.
        """
        now, seq = self.now, self._seq
        batch = [(when if when > now else now, next(seq), args) for when, args in calls]
        if not batch:
            return
        if len(batch) == 1:
            when, number, args = batch[0]
            heapq.heappush(self._queue, (when, number, fn, args))
            return
        batch.sort()  # by time, then scheduling order (unique: args never compared)
        when, number, _ = batch[0]
        heapq.heappush(self._queue, (when, number, _RUN, [0, fn, batch]))

    def next_time(self) -> float | None:
        """When the next event runs, or None when none is queued."""
        return self._queue[0][0] if self._queue else None

    def _take(self) -> tuple[Callable[..., Any], Any]:
        """Remove the next call from the queue; return its function and arguments."""
        queue = self._queue
        _, _, fn, args = queue[0]
        if fn is not _RUN:
            heapq.heappop(queue)
            return fn, args
        index, fn, batch = args
        call_args = batch[index][2]
        index += 1
        if index < len(batch):
            args[0] = index
            heapq.heapreplace(queue, (batch[index][0], batch[index][1], _RUN, args))
        else:
            heapq.heappop(queue)
        return fn, call_args

    def run_until(self, end: float, stop: Callable[[], bool] | None = None) -> bool:
        """Run every event due up to ``end``, then set the clock to ``end``.

        Args:
            end: the virtual time to reach.
            stop: checked after each event; when it returns True the run ends there.

        Returns:
            True when ``stop`` ended the run early.
        """
        with _collections_spaced():
            return self._run_until(end, stop)

    def _run_until(self, end: float, stop: Callable[[], bool] | None) -> bool:
        queue = self._queue
        if stop is None:
            # The loop of every simulation step, with ``_take`` written out: it runs
            # once per delivered frame.
            pop, replace = heapq.heappop, heapq.heapreplace
            ran = 0
            try:
                while queue and queue[0][0] <= end:
                    when, _, fn, args = queue[0]
                    if fn is _RUN:
                        index, fn, batch = args
                        call_args = batch[index][2]
                        index += 1
                        if index < len(batch):
                            args[0] = index
                            nxt = batch[index]
                            replace(queue, (nxt[0], nxt[1], _RUN, args))
                        else:
                            pop(queue)
                        args = call_args
                    else:
                        pop(queue)
                    self.now = when
                    ran += 1
                    fn(*args)
            finally:
                self.events_run += ran
        else:
            while queue and queue[0][0] <= end:
                when = queue[0][0]
                fn, args = self._take()
                self.now = when
                fn(*args)
                self.events_run += 1
                if stop():
                    return True
        if end > self.now:
            self.now = end
        return False
