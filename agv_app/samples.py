"""Bounded statistics of a long run: exact count, sum and maximum, recent values kept.

A fleet that runs for days records task times and lock waits without end; keeping every
value would grow without bound. :class:`Samples` keeps the count, the sum and the
maximum of everything it was given, so means and maxima stay exact, and the last
``keep`` values, from which percentiles are computed.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterator

__all__ = ["DEFAULT_KEEP", "Samples", "percentile"]

DEFAULT_KEEP = 10_000
"""How many recent values a :class:`Samples` keeps for percentiles by default."""


def percentile(values: list[float], q: float) -> float:
    """The ``q``-th percentile (0..100) by linear interpolation; 0 for no values."""
    if not values:
        return 0.0
    xs = sorted(values)
    k = (len(xs) - 1) * q / 100
    lo, hi = math.floor(k), math.ceil(k)
    return xs[lo] + (xs[hi] - xs[lo]) * (k - lo)


class Samples:
    """A stream of values: exact count, sum, mean and maximum; the last ``keep`` values.

    Args:
        keep: how many of the most recent values to keep (at least 1).

    Raises:
        ValueError: ``keep`` is less than 1.
    """

    __slots__ = ("_recent", "count", "maximum", "total")

    def __init__(self, *, keep: int = DEFAULT_KEEP) -> None:
        if keep < 1:
            raise ValueError(f"keep must be at least 1, got {keep!r}")
        self._recent: deque[float] = deque(maxlen=keep)
        self.count = 0
        """Values given so far."""
        self.total = 0.0
        """Their sum."""
        self.maximum = 0.0
        """The largest (0 before the first)."""

    def append(self, value: float) -> None:
        """Record one value."""
        self._recent.append(value)
        self.count += 1
        self.total += value
        self.maximum = value if self.count == 1 else max(self.maximum, value)

    @property
    def mean(self) -> float:
        """The mean of every value given (0 before the first)."""
        return self.total / self.count if self.count else 0.0

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile of the recent values (all of them if fewer than ``keep``)."""
        return percentile(list(self._recent), q)

    def recent(self) -> list[float]:
        """The recent values, oldest first."""
        return list(self._recent)

    def __len__(self) -> int:
        return self.count

    def __iter__(self) -> Iterator[float]:
        return iter(self._recent)
