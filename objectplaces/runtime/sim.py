"""A virtual clock and an event queue: simulated time only moves when events run."""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Iterable
from typing import Any

__all__ = ["EventLoop"]


class EventLoop:
    """Runs scheduled calls in time order; ties keep their scheduling order."""

    def __init__(self, start: float = 0.0) -> None:
        self.now = start
        self._queue: list[tuple[float, int, Callable[..., Any], tuple[Any, ...]]] = []
        self._seq = itertools.count()
        self.events_run = 0

    def __len__(self) -> int:
        return len(self._queue)

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` at virtual time ``when`` (now if it lies in the past)."""
        now = self.now
        heapq.heappush(self._queue, (when if when > now else now, next(self._seq), fn, args))

    def call_each(
        self, fn: Callable[..., Any], calls: Iterable[tuple[float, tuple[Any, ...]]]
    ) -> None:
        """``call_at(when, fn, *args)`` for each ``(when, args)``, in that order.

        The simulated network schedules one arrival per recipient of a frame: one call
        for them all saves a method call and an argument tuple per recipient.
        """
        queue, seq, now = self._queue, self._seq, self.now
        push = heapq.heappush
        for when, args in calls:
            push(queue, (when if when > now else now, next(seq), fn, args))

    def next_time(self) -> float | None:
        """When the next event runs, or None when none is queued."""
        return self._queue[0][0] if self._queue else None

    def run_until(self, end: float, stop: Callable[[], bool] | None = None) -> bool:
        """Run every event due up to ``end``, then set the clock to ``end``.

        Args:
            end: the virtual time to reach.
            stop: checked after each event; when it returns True the run ends there.

        Returns:
            True when ``stop`` ended the run early.
        """
        queue = self._queue
        pop = heapq.heappop
        if stop is None:
            # The loop of every simulation step: nothing checked between events.
            ran = 0
            try:
                while queue and queue[0][0] <= end:
                    when, _, fn, args = pop(queue)
                    self.now = when
                    ran += 1
                    fn(*args)
            finally:
                self.events_run += ran
        else:
            while queue and queue[0][0] <= end:
                when, _, fn, args = pop(queue)
                self.now = when
                fn(*args)
                self.events_run += 1
                if stop():
                    return True
        if end > self.now:
            self.now = end
        return False
