"""A stand-in for a real vehicle, written against the driver interface alone.

:class:`StandInDriver` keeps a ground truth of its own (where the vehicle truly is, how
fast it truly goes) and tells the controller only what a real vehicle's driver would
(:mod:`agv_app.vehicle.driver`), with the flaws of one (:class:`Flaws`):

* its pose reports are off by up to ``noise_m``, in position and in progress along the
  route;
* they come late (a latency and a random jitter on top, so out of order too), some
  never (``drop``), and from ``silent_after`` on none at all;
* its motion control plans its stops with the declared ``brake_m_s2``, but the brake
  truly achieves ``Flaws.brake_m_s2``, which may be less: within the declared
  ``min_brake_m_s2`` the controller's margin keeps it inside its locks; below it, not.

It moves in steps of 10 ms within each ``tick``: it accelerates or cruises while it
could still stop at its limit braking as planned, else it brakes with its true brake.
Near a limit it creeps, and within 0.1 mm it stands at it. Past its route's ends it
moves on along the first and last piece (where a weak brake takes it). ``follow``
puts it on the new route where it truly stands, measured along the route (a little
short of the route's start, if it stopped short of its last limit).

The truth (``true_pose``, ``true_hull``) is for the simulation's safety monitor and the
tests; the controller never sees it. Given a state file, it keeps its true pose there,
as a real vehicle knows where it stands after its process restarts
(:meth:`StandInDriver.recovered`).
"""

from __future__ import annotations

import heapq
import math
import random
from collections.abc import Sequence
from dataclasses import dataclass

from agv_app.geometry import Area, Polyline, Pose, hull
from agv_app.vehicle.driver import (
    DriverEvent,
    DriverLimits,
    PoseReport,
    PoseReported,
    Stopped,
)
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.state_file import StateFile, pose_from_json, pose_to_json

__all__ = ["Flaws", "StandInDriver", "standin_limits"]

_STEP_S = 0.01
_CREEP_M = 1e-4


@dataclass(frozen=True, slots=True)
class Flaws:
    """How the stand-in falls short of an ideal vehicle (metres, seconds).

    Attributes:
        noise_m: reported position and progress off by up to this (at most the
            declared localization error, or the controller finds it off its route).
        report_interval_s: it measures its pose this often.
        latency_s: every report arrives at least this late.
        jitter_s: and up to this much later still, at random.
        drop: the share of reports that never arrive.
        brake_m_s2: what its brake truly achieves (None: the declared ``brake_m_s2``).
        silent_after: no report measured from this time on (None: never).
    """

    noise_m: float = 0.03
    report_interval_s: float = 0.1
    latency_s: float = 0.05
    jitter_s: float = 0.25
    drop: float = 0.1
    brake_m_s2: float | None = None
    silent_after: float | None = None


def standin_limits(
    spec: VehicleSpec,
    *,
    min_brake_m_s2: float | None = None,
    localization_error_m: float = 0.05,
    report_timeout_s: float = 1.0,
) -> DriverLimits:
    """What a stand-in of ``spec`` declares: its speed and acceleration, braking planned
    at the acceleration, at least ``min_brake_m_s2`` (default: 80 % of it)."""
    a = spec.max_accel_m_s2
    return DriverLimits(
        spec.max_speed_m_s,
        a,
        a,
        0.8 * a if min_brake_m_s2 is None else min_brake_m_s2,
        localization_error_m,
        report_timeout_s,
    )


class StandInDriver:
    """A vehicle with flaws behind the driver interface (the module docstring).

    Args:
        spec: its true size.
        pose: where it stands, at rest.
        limits: what it declares.
        flaws: how it falls short.
        seed: seeds its noise, jitter and losses.
        state: where it keeps its true pose (None: nowhere).
    """

    def __init__(
        self,
        spec: VehicleSpec,
        pose: Pose,
        *,
        limits: DriverLimits,
        flaws: Flaws | None = None,
        seed: int = 0,
        state: StateFile | None = None,
    ) -> None:
        self.spec = spec
        self.limits = limits
        self.flaws = flaws = flaws or Flaws()
        self._rng = random.Random(seed)
        self._route = Polyline([(pose.x, pose.y)], heading_rad=pose.heading_rad)
        self._s = 0.0
        self._v = 0.0
        self._limit = 0.0
        self._stopping = False
        self._brake = limits.brake_m_s2 if flaws.brake_m_s2 is None else flaws.brake_m_s2
        self._next_measure: float | None = None
        self._now = 0.0
        self._mail: list[tuple[float, int, DriverEvent]] = []  # (arrives, order, event)
        self._order = 0
        self.measured = 0
        """Pose reports measured (sent or lost)."""
        self.lost = 0
        """Reports lost on the way (``drop``)."""
        self._state = state
        self._kept: Pose | None = None
        self._events: list[DriverEvent] = [PoseReported(self._report(0.0, exact=True))]
        self._keep()

    @classmethod
    def recovered(
        cls,
        spec: VehicleSpec,
        state: StateFile,
        *,
        default: Pose,
        limits: DriverLimits,
        flaws: Flaws | None = None,
        seed: int = 0,
    ) -> StandInDriver:
        """The stand-in where its state file says it stands, else at ``default``.

        Raises:
            StateFileError: the file holds no pose.
        """
        document = state.read()
        pose = default if document is None else pose_from_json(document, where=str(state.path))
        return cls(spec, pose, limits=limits, flaws=flaws, seed=seed, state=state)

    # -- the driver interface -------------------------------------------------------

    def follow(self, route: Polyline, *, s: float) -> None:
        """Follow ``route``, placed on it where it truly stands (near ``s``)."""
        x, y = self.true_pose().x, self.true_pose().y
        px, py = route.point_at(s)
        heading = route.heading_at(s)
        along = (x - px) * math.cos(heading) + (y - py) * math.sin(heading)
        self._route = route
        self._s = s + along

    def shorten(self, length: float) -> None:
        """End the route at ``length`` (it never stands beyond it when told so)."""
        self._route = self._route.slice(0.0, length)

    def drive(self, limit_s: float) -> None:
        """Drive on, stopping at ``limit_s`` as planned."""
        self._limit = limit_s
        self._stopping = False

    def stop(self) -> None:
        """Brake with the true brake until it stands."""
        self._stopping = True

    def tick(self, dt: float, *, now: float) -> None:
        """Move ``dt`` seconds in steps of 10 ms, measure, and deliver what is due."""
        n = max(1, math.ceil(dt / _STEP_S - 1e-9))
        h = dt / n
        start = now - dt
        for k in range(n):
            moving = self._v > 0.0
            self._advance(h)
            t = start + (k + 1) * h
            if moving and self._v == 0.0:
                self._post(t + self.flaws.latency_s, Stopped(t))
            if self._next_measure is None or t >= self._next_measure - 1e-9:
                self._next_measure = t + self.flaws.report_interval_s
                self._measure(t)
        self._now = now
        self._keep()
        while self._mail and self._mail[0][0] <= now:
            self._events.append(heapq.heappop(self._mail)[2])

    def events(self) -> Sequence[DriverEvent]:
        """What arrived since the last call."""
        out, self._events = self._events, []
        return out

    # -- the truth ------------------------------------------------------------------

    @property
    def true_s(self) -> float:
        """Arc length it truly stands at along its route (may lie past either end)."""
        return self._s

    @property
    def true_speed(self) -> float:
        """Its true speed, m/s."""
        return self._v

    def true_pose(self) -> Pose:
        """Where it truly stands."""
        route, s = self._route, self._s
        if len(route.coords) == 1 or 0.0 <= s <= route.length:
            return route.pose_at(s)
        end = 0.0 if s < 0.0 else route.length
        pose = route.pose_at(end)
        beyond = s - end
        return Pose(
            pose.x + beyond * math.cos(pose.heading_rad),
            pose.y + beyond * math.sin(pose.heading_rad),
            pose.heading_rad,
        )

    def true_hull(self) -> Area:
        """The rectangle it truly covers."""
        return hull(self.true_pose(), length=self.spec.length_m, width=self.spec.width_m)

    # -- inside ---------------------------------------------------------------------

    def _advance(self, h: float) -> None:
        s, v = self._s, self._v
        if not self._stopping:
            limits = self.limits
            limit = min(self._limit, self._route.length)
            planned = 2.0 * limits.brake_m_s2
            v1 = min(limits.max_speed_m_s, v + limits.accel_m_s2 * h)
            s1 = s + (v + v1) / 2 * h
            if s1 + v1 * v1 / planned <= limit:
                self._s, self._v = s1, v1
                return
            if v > 0.0 and s + v * h + v * v / planned <= limit:
                self._s = s + v * h
                return
            if v == 0.0:
                if 0.0 < limit - s <= _CREEP_M:
                    self._s = limit  # it comes to rest at the limit
                return
        brake = self._brake
        if v <= brake * h:
            self._s, self._v = s + v * v / (2 * brake), 0.0
        else:
            v1 = v - brake * h
            self._s, self._v = s + (v + v1) / 2 * h, v1

    def _measure(self, t: float) -> None:
        flaws = self.flaws
        if flaws.silent_after is not None and t >= flaws.silent_after:
            return
        self.measured += 1
        if self._rng.random() < flaws.drop:
            self.lost += 1
            return
        arrives = t + flaws.latency_s + self._rng.uniform(0.0, flaws.jitter_s)
        self._post(arrives, PoseReported(self._report(t, exact=False)))

    def _post(self, arrives: float, event: DriverEvent) -> None:
        self._order += 1
        heapq.heappush(self._mail, (arrives, self._order, event))

    def _report(self, t: float, *, exact: bool) -> PoseReport:
        pose = self.true_pose()
        if exact:
            return PoseReport(pose.x, pose.y, pose.heading_rad, t, self._v, self._s)
        rng, noise = self._rng, self.flaws.noise_m
        r, angle = noise * math.sqrt(rng.random()), rng.uniform(0.0, math.tau)
        return PoseReport(
            pose.x + r * math.cos(angle),
            pose.y + r * math.sin(angle),
            pose.heading_rad + rng.uniform(-0.01, 0.01),
            t,
            self._v,
            self._s + rng.uniform(-noise, noise),
        )

    def _keep(self) -> None:
        if self._state is None:
            return
        pose = self.true_pose()
        if pose != self._kept:
            self._state.write(pose_to_json(pose), durable=self._v == 0.0)
            self._kept = pose
