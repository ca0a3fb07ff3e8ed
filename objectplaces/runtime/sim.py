"""A virtual clock and an event queue: simulated time only moves when events run."""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable
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
        heapq.heappush(self._queue, (max(when, self.now), next(self._seq), fn, args))

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
        while queue and queue[0][0] <= end:
            when, _, fn, args = pop(queue)
            self.now = when
            fn(*args)
            self.events_run += 1
            if stop is not None and stop():
                return True
        self.now = max(self.now, end)
        return False
