"""How fast the fleet really runs: wall-clock time run and simulated time gained.

The fleets report ``wall_seconds`` and ``sim_speed`` only for a batch run, where they
know the wall time; live, only the dashboard's driver does. :class:`RunClock` adds up the
wall-clock seconds the fleet ran (not paused) and the simulated seconds it gained in
them, and the dashboard reports both figures in place of the fleet's. Pure: the driver
passes the wall time elapsed and the fleet's clock.
"""

from __future__ import annotations

__all__ = ["RunClock"]


class RunClock:
    """Wall-clock seconds run and simulated seconds gained while not paused."""

    def __init__(self) -> None:
        self.wall_seconds = 0.0
        """Wall-clock seconds the fleet ran (paused time excluded)."""
        self.sim_seconds = 0.0
        """Simulated seconds the fleet gained in them."""
        self._last_sim: float | None = None

    def tick(self, wall_elapsed: float, sim_now: float, *, paused: bool) -> None:
        """``wall_elapsed`` seconds went by and the fleet's clock now reads ``sim_now``."""
        if self._last_sim is not None and not paused and wall_elapsed > 0:
            self.wall_seconds += wall_elapsed
            self.sim_seconds += max(0.0, sim_now - self._last_sim)
        self._last_sim = sim_now

    def figures(self) -> dict[str, float]:
        """``wall_seconds`` and ``sim_speed`` (simulated per wall second achieved, 0 before
        the fleet ran), rounded as the fleets round them."""
        speed = self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else 0.0
        return {"wall_seconds": round(self.wall_seconds, 3), "sim_speed": round(speed, 2)}
