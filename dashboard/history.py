"""The fleet's figures over time: a bounded ring of samples, and the orders' wait times.

:class:`MetricsHistory` keeps one :class:`Sample` at most every ``every_s`` simulated
seconds (the fleet's metrics, and the frames sent so far by kind, summed over every
node), the newest ``capacity`` of them; older ones are dropped and counted. Pure: the
caller passes ``now`` and what it read. :class:`HistorySampler` reads the dashboard's
state for it a few times a wall-clock second (``GET /api/metrics/history``).

:func:`wait_histogram` counts how long transport orders waited for a vehicle (from
``created`` to ``assigned``) into fixed bins, so plots of two runs compare at a glance.
"""

from __future__ import annotations

import asyncio
import bisect
import csv
import io
import logging
import math
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from dashboard.source import TaskBookSource
from dashboard.state import DashboardState

__all__ = [
    "DEFAULT_CAPACITY",
    "DEFAULT_EVERY_S",
    "WAIT_EDGES_S",
    "HistorySampler",
    "MetricsHistory",
    "Sample",
    "order_waits",
    "sent_by_kind",
    "wait_histogram",
]

DEFAULT_EVERY_S = 5.0
"""Simulated seconds between two samples by default."""

DEFAULT_CAPACITY = 720
"""Samples kept by default: an hour at one sample every 5 s."""

WAIT_EDGES_S: tuple[float, ...] = (0.0, 2.0, 5.0, 10.0, 20.0, 30.0, 60.0, 120.0, 300.0)
"""Lower edges of the wait-time bins, seconds; the last bin has no upper edge."""

_KIND_PREFIX = "sent:"
_EPSILON_S = 1e-6

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Sample:
    """The fleet at one instant.

    Attributes:
        time: simulated seconds.
        metrics: the fleet's figures (non-finite ones left out).
        sent: frames sent so far by message kind, summed over every node.
    """

    time: float
    metrics: Mapping[str, float] = field(default_factory=dict)
    sent: Mapping[str, int] = field(default_factory=dict)

    def as_json(self) -> dict[str, Any]:
        """The sample as a JSON object."""
        return {"time": self.time, "metrics": dict(self.metrics), "sent": dict(self.sent)}


class MetricsHistory:
    """The newest ``capacity`` samples, at least ``every_s`` simulated seconds apart.

    Args:
        every_s: least simulated time between two samples.
        capacity: most samples kept.

    Raises:
        ValueError: ``every_s`` not positive or ``capacity`` below 2.
    """

    def __init__(self, *, every_s: float = DEFAULT_EVERY_S, capacity: int = DEFAULT_CAPACITY):
        if not (math.isfinite(every_s) and every_s > 0):
            raise ValueError(f"every_s must be a positive number, got {every_s!r}")
        if capacity < 2:
            raise ValueError(f"capacity must be at least 2, got {capacity!r}")
        self.every_s = every_s
        self.capacity = capacity
        self.dropped = 0
        """Samples no longer kept (the ring was full)."""
        self._samples: deque[Sample] = deque(maxlen=capacity)

    def __len__(self) -> int:
        """Samples kept."""
        return len(self._samples)

    def due(self, now: float) -> bool:
        """Whether a sample taken at ``now`` would be kept (always after the clock went
        back)."""
        if not self._samples:
            return True
        last = self._samples[-1].time
        # A fleet that steps in fixed increments reaches 10.0 as 9.999999...
        return now < last or now - last >= self.every_s - _EPSILON_S

    def record(self, now: float, metrics: Mapping[str, float], sent: Mapping[str, int]) -> bool:
        """Keep a sample at ``now`` if it is due; whether it was kept.

        A clock that went back (a fleet restarted) starts the history afresh.
        """
        if self._samples and now < self._samples[-1].time:
            self.dropped += len(self._samples)
            self._samples.clear()
        if not self.due(now):
            return False
        if len(self._samples) == self.capacity:
            self.dropped += 1
        finite = {str(k): float(v) for k, v in metrics.items() if math.isfinite(float(v))}
        self._samples.append(Sample(float(now), finite, {str(k): int(v) for k, v in sent.items()}))
        return True

    def samples(self, limit: int | None = None) -> list[Sample]:
        """The samples kept, oldest first; only the newest ``limit`` when given."""
        out = list(self._samples)
        return out if limit is None else out[-limit:] if limit > 0 else []

    def as_csv(self, limit: int | None = None) -> str:
        """The samples as CSV: ``time``, one column per metric, one ``sent:<kind>`` per kind.

        Columns are the union over the samples, sorted; a value a sample lacks is empty.
        """
        samples = self.samples(limit)
        metric_names = sorted({k for s in samples for k in s.metrics})
        kinds = sorted({k for s in samples for k in s.sent})
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["time", *metric_names, *(_KIND_PREFIX + k for k in kinds)])
        for s in samples:
            writer.writerow(
                [
                    _cell(s.time),
                    *(_cell(s.metrics.get(k)) for k in metric_names),
                    *(_cell(s.sent.get(k)) for k in kinds),
                ]
            )
        return buffer.getvalue()


def _cell(value: float | None) -> str:
    return "" if value is None else repr(value)


def wait_histogram(waits: Iterable[float], edges: tuple[float, ...] = WAIT_EDGES_S) -> list[int]:
    """How many of ``waits`` (seconds) fall in each bin ``[edges[i], edges[i+1])``.

    The last bin counts everything from ``edges[-1]`` on; a wait below ``edges[0]`` or
    not a finite number is left out.
    """
    counts = [0] * len(edges)
    for wait in waits:
        if math.isfinite(wait) and wait >= edges[0]:
            counts[bisect.bisect_right(edges, wait) - 1] += 1
    return counts


def order_waits(source: object) -> list[float]:
    """Seconds each order the fleet's task book holds waited for a vehicle (created to
    assigned); orders still waiting are left out. Empty for a fleet without a book."""
    if not isinstance(source, TaskBookSource):
        return []
    waits: list[float] = []
    for record in source.task_records():
        times = record.times
        created, assigned = times.get("created"), times.get("assigned")
        if created is not None and assigned is not None:
            waits.append(max(0.0, float(assigned) - float(created)))
    return waits


def sent_by_kind(state: DashboardState) -> dict[str, int]:
    """Frames sent so far by message kind, summed over every node the fleet shows."""
    totals: dict[str, int] = {}
    for node in state.source.nodes().values():
        for kind, (frames, _bytes) in node.stats().sent.items():
            totals[kind] = totals.get(kind, 0) + int(frames)
    return totals


class HistorySampler:
    """Takes a sample of the dashboard's fleet into ``history`` whenever one is due.

    Args:
        state: the dashboard's state (its fleet, metrics and nodes).
        history: where the samples go.
        look_every_s: wall-clock seconds between two looks at the fleet's clock.
    """

    def __init__(
        self, state: DashboardState, history: MetricsHistory, *, look_every_s: float = 0.25
    ) -> None:
        self.state = state
        self.history = history
        self.look_every_s = look_every_s
        self.failures = 0
        """Looks that raised so far (the first is logged with its traceback)."""

    def sample(self) -> bool:
        """Record a sample if one is due at the fleet's current time; whether it was."""
        now = float(self.state.source.now)
        if not self.history.due(now):
            return False
        return self.history.record(now, self.state.metrics(), sent_by_kind(self.state))

    async def run(self) -> None:
        """Look every ``look_every_s`` until cancelled; a look that fails is logged and
        skipped (a gap in the plots, never a stopped dashboard)."""
        while True:
            try:
                self.sample()
            except Exception:
                self.failures += 1
                if self.failures == 1:
                    log.exception("sampling the metrics history failed; sampling goes on")
            await asyncio.sleep(self.look_every_s)
