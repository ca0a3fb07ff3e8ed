"""The task that advances the fleet in real time and feeds the page.

``FleetDriver.run`` wakes every ``tick_s``, advances the fleet by the wall time elapsed
times its speed (at most ``max_step_s`` of wall time per step, so a stalled loop does
not make the fleet jump), and every so often offers a fresh state to the feed,
registers the poll responder on new nodes, forgets HTTP sessions that ended and logs
what changed in the fleet (``dashboard.watch``). Each of
these is one synchronous call on the event loop, so it never interleaves with a request
handler (``dashboard.app``).

Failure policy: the fleet pauses only when someone asks for it. An exception raised by
one advance (or by a capture for the feed) is logged and counted, and the driver goes
on with the next tick: a bug in one step must not freeze a live fleet for good. The
first failure is logged with its traceback, later ones at most once every
``report_every_s`` with their count, so a failure that repeats cannot flood the log.
``advance_errors`` is shown by ``GET /api/metrics``.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Callable

from dashboard.state import DashboardState

__all__ = ["FleetDriver"]

log = logging.getLogger(__name__)


class FleetDriver:
    """Advances ``state.source`` in real time and keeps the dashboard's state current.

    Args:
        state: the dashboard's state (its ``source`` is the fleet).
        tick_s: wall-clock seconds between two steps.
        max_step_s: most wall-clock seconds one step covers.
        publish_s: least time between two states offered to the feed.
        counters_s: least time between two readings of the per-node counters.
        housekeeping_s: least time between two rounds of registering responders and
            forgetting ended sessions.
        report_every_s: least time between two log lines about repeated failures.
    """

    def __init__(
        self,
        state: DashboardState,
        *,
        tick_s: float = 0.02,
        max_step_s: float = 0.1,
        publish_s: float = 0.05,
        counters_s: float = 0.5,
        housekeeping_s: float = 0.25,
        report_every_s: float = 10.0,
    ) -> None:
        self.state = state
        self.tick_s = tick_s
        self.max_step_s = max_step_s
        self.publish_s = publish_s
        self.counters_s = counters_s
        self.housekeeping_s = housekeeping_s
        self.report_every_s = report_every_s
        self.advance_errors = 0
        """Advances that raised so far."""
        self.publish_errors = 0
        """Captures for the feed that raised so far."""
        self._last_step: float | None = None
        self._last_publish = -math.inf
        self._last_counters = -math.inf
        self._last_housekeeping = -math.inf
        self._last_report = -math.inf
        self._unreported = 0

    def step(self, now: float) -> None:
        """One tick at wall-clock time ``now`` (any monotonic clock, the same each call)."""
        elapsed = 0.0 if self._last_step is None else now - self._last_step
        self._last_step = now
        source = self.state.source
        paused = bool(source.paused)
        if not paused and elapsed > 0:
            seconds = min(elapsed, self.max_step_s) * source.speed
            try:
                source.advance(seconds)
            except Exception as exc:
                self.advance_errors += 1
                self._report(now, "advancing the fleet", exc)
        self.state.clock.tick(elapsed, float(source.now), paused=paused)
        if now - self._last_housekeeping >= self.housekeeping_s:
            self._last_housekeeping = now
            self._guarded(now, "housekeeping", self._housekeeping)
        if now - self._last_publish >= self.publish_s:
            self._last_publish = now
            fresh = now - self._last_counters >= self.counters_s
            if fresh:
                self._last_counters = now
            if not self._guarded(now, "capturing the fleet for the feed", self._publisher(fresh)):
                self.publish_errors += 1

    async def run(self) -> None:
        """Step every ``tick_s`` until cancelled."""
        loop = asyncio.get_running_loop()
        while True:
            self.step(loop.time())
            await asyncio.sleep(self.tick_s)

    def _housekeeping(self) -> None:
        self.state.ensure_responders()
        now = float(self.state.source.now)
        for session_id in self.state.prune():
            self.state.events.record(now, "info", "api", f"session {session_id} ended")
        self.state.watch_fleet()

    def _publisher(self, fresh: bool) -> Callable[[], None]:
        return lambda: self.state.publish(fresh_counters=fresh)

    def _guarded(self, now: float, what: str, action: Callable[[], None]) -> bool:
        try:
            action()
        except Exception as exc:
            self._report(now, what, exc)
            return False
        return True

    def _report(self, now: float, what: str, exc: Exception) -> None:
        self._unreported += 1
        if self._last_report == -math.inf:
            log.error("%s failed; the fleet keeps running", what, exc_info=exc)
        elif now - self._last_report >= self.report_every_s:
            log.error(
                "%s failed again: %r (%d failures since the last report); the fleet keeps running",
                what,
                exc,
                self._unreported,
            )
        else:
            return
        self._last_report = now
        self._unreported = 0
