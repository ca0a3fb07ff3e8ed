"""A virtual clock and an event queue: simulated time only moves when events run.

Events run in the order of ``(time, scheduling order)``. The queue is a binary heap.
A frame sent to many nodes schedules one arrival per recipient, and a large network's
heartbeats leave together: 200 nodes put 40,000 arrivals in the heap at one instant,
and each push and pop then walks a deep heap that no longer fits the cache. So what
one event schedules waits outside the heap until the event is done, and then enters it
sorted, as one *run*, of which only the next call sits in the heap: a k-way merge of
the runs. The order is the same as with every call in the heap (the merge yields the
smallest ``(time, scheduling order)`` first, and each call keeps the place in the
scheduling order it was given when scheduled); only the heap is smaller.
"""

from __future__ import annotations

import contextlib
import gc
import heapq
import itertools
from collections.abc import Callable, Iterable, Iterator
from typing import Any

__all__ = ["GC_ALLOCATIONS", "EventLoop", "collections_spaced"]


def _run_marker() -> None:
    """Stands in a heap entry for a run: its ``args`` is ``[next index, sorted calls]``."""


_RUN: Callable[..., Any] = _run_marker

_Entry = tuple[float, int, Callable[..., Any], Any]


GC_ALLOCATIONS = 100_000
"""Allocations between two young-generation collections while events run (Python's
default is 700). A simulation allocates a tuple per arrival and keeps a large state
alive; at the default, the collector's passes over that state cost a third of a
200-node run. Cycles wait a little longer to be freed; nothing else changes."""


@contextlib.contextmanager
def collections_spaced() -> Iterator[None]:
    """Space the collector's passes to ``GC_ALLOCATIONS`` for the block, then restore.

    ``run_until`` does it for the events it runs; a driver that calls it in steps, with
    work of its own between them, puts its whole run in the block: else each step's
    end restores the default, and the next allocation collects what the step made.
    """
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
        self._queue: list[_Entry] = []
        # Calls scheduled since the heap was last brought up to date (see the module).
        self._pending: list[_Entry] = []
        self._seq = itertools.count()
        self.events_run = 0

    def __len__(self) -> int:
        """How many entries the heap holds (a run of calls counts once)."""
        self._flush()
        return len(self._queue)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` at virtual time ``when`` (now if it lies in the past)."""
        now = self.now
        self._pending.append((when if when > now else now, next(self._seq), fn, args))

    def call_each(
        self, fn: Callable[..., Any], calls: Iterable[tuple[float, tuple[Any, ...]]]
    ) -> None:
        """``call_at(when, fn, *args)`` for each ``(when, args)``, in that order (one
        call for a frame's many arrivals)."""
        now, seq = self.now, self._seq
        self._pending.extend(
            (when if when > now else now, next(seq), fn, args) for when, args in calls
        )

    def next_time(self) -> float | None:
        """When the next event runs, or None when none is queued."""
        self._flush()
        return self._queue[0][0] if self._queue else None

    def _flush(self) -> None:
        """Move the pending calls into the heap: one entry, or one sorted run."""
        pending = self._pending
        if not pending:
            return
        if len(pending) == 1:
            heapq.heappush(self._queue, pending[0])
        else:
            batch = sorted(pending)  # by time, then scheduling order (unique: never fn)
            heapq.heappush(self._queue, (batch[0][0], batch[0][1], _RUN, [0, batch]))
        pending.clear()

    def _take(self) -> tuple[Callable[..., Any], Any]:
        """Remove the next call from the heap; return its function and arguments."""
        queue = self._queue
        _, _, fn, args = queue[0]
        if fn is not _RUN:
            heapq.heappop(queue)
            return fn, args
        index, batch = args
        _, _, fn, call_args = batch[index]
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
        with collections_spaced():
            return self._run_until(end, stop)

    def _run_until(self, end: float, stop: Callable[[], bool] | None) -> bool:
        queue, pending, flush = self._queue, self._pending, self._flush
        flush()
        if stop is None:
            # The loop of every simulation step, with ``_take`` written out: it runs
            # once per delivered frame.
            pop, replace = heapq.heappop, heapq.heapreplace
            ran = 0
            try:
                while queue and queue[0][0] <= end:
                    when, _, fn, args = queue[0]
                    if fn is _RUN:
                        index, batch = args
                        _, _, fn, call_args = batch[index]
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
                    if pending:
                        flush()
            finally:
                self.events_run += ran
        else:
            while queue and queue[0][0] <= end:
                when = queue[0][0]
                fn, args = self._take()
                self.now = when
                fn(*args)
                flush()
                self.events_run += 1
                if stop():
                    return True
        if end > self.now:
            self.now = end
        return False
