"""The vehicle as the controller knows it: through its driver, with what it declares.

:class:`DrivenVehicle` is what :class:`~agv_app.vehicle.controller.AgvController` holds
as ``vehicle``: the route it gave the driver, how far along it the vehicle has come
at least, its speed, and the commands. It talks to the driver only through
:class:`~agv_app.vehicle.driver.VehicleDriver`, and turns what the driver declares into
what the traffic control plans with (docs/drivers.md):

* **Progress is a lower bound.** ``s`` is the reported arc length less the
  localization error, never decreasing: the vehicle is at least that far. Releases cut
  the locks behind it there, so a report that comes late, or not at all, only keeps
  floor longer. Reports measured before the newest one, or before the route began,
  are dropped.
* **The hull is grown** on every side by twice the error (the vehicle is off its
  report by up to the error along the route and across it), and by how far short of
  a limit a vehicle whose brake may fall short can come to rest (below), so a vehicle
  counted as arrived is inside the hull at its destination.
  :func:`planning_spec` is the vehicle's spec with that hull, braking at the least
  deceleration declared: what ``need`` and the projections use.
* **The limit keeps a margin.** The vehicle plans its stops with ``brake_m_s2``; its
  brake may achieve only ``min_brake_m_s2``, which stops it further on by
  ``c * v**2``, ``c = (1/min_brake - 1/brake) / 2``. The limit given is the end of the
  locks less ``c * v_b**2``, ``v_b`` the fastest it may go before the next command:
  the last reported speed plus what it gains at full acceleration since that report
  and during the next step. A vehicle that keeps to its plan then stops within its
  locks, and one braking on (a limit pulled back) only comes closer to its stop.
  Near a stop the margin shrinks with the speed; at rest it stays a few millimetres,
  so at its route's end the vehicle stops that short, and counts as arrived when
  ``s`` lies within the hull's growth of the end while it stands.
* **Silence is a fault.** No report measured for ``report_timeout_s``, a report off
  the route by more than three times the error (a driver that declares none is taken
  at its word), or a driver's fault event: the
  vehicle is told to stop and :attr:`DrivenVehicle.fault` says why; the controller
  then counts itself failed (its runner takes its node off the network, the others
  keep its last circle).

With the simulated driver (exact reports, the brake as planned) all of this is the
identity: the same floats as the kinematics, so seeded simulations keep their figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from agv_app.geometry import Area, Polyline, Pose, hull
from agv_app.vehicle.driver import (
    DriverEvent,
    DriverLimits,
    PoseReport,
    PoseReported,
    Stopped,
    VehicleDriver,
)
from agv_app.vehicle.kinematics import Vehicle, VehicleSpec
from agv_app.vehicle.sim_driver import SimDriver

__all__ = ["DrivenVehicle", "brake_margin_factor", "hull_growth", "planning_spec"]

_STEP_ALLOWANCE_S = 0.2
"""A control step and some lag, after the last report the margin allows for (only how
soon a vehicle counts as arrived depends on it)."""
_SLACK_M = 1e-9


def brake_margin_factor(limits: DriverLimits) -> float:
    """``c``: a brake at ``min_brake`` instead of ``brake`` stops ``c * v**2`` further."""
    return (1.0 / limits.min_brake_m_s2 - 1.0 / limits.brake_m_s2) / 2.0


def hull_growth(limits: DriverLimits) -> float:
    """Metres the planned hull grows on every side: twice the localization error, plus
    the margin at rest with the oldest report that is no fault yet."""
    grow = 2.0 * limits.localization_error_m
    c = brake_margin_factor(limits)
    if c > 0.0:
        assert limits.report_timeout_s is not None  # DriverLimits insists
        v = min(
            limits.max_speed_m_s, limits.accel_m_s2 * (limits.report_timeout_s + _STEP_ALLOWANCE_S)
        )
        grow += c * v * v
    return grow


def planning_spec(spec: VehicleSpec, limits: DriverLimits) -> VehicleSpec:
    """The spec the traffic control plans with: the hull grown (:func:`hull_growth`),
    the declared top speed, braking at the least deceleration declared; ``spec`` itself
    when that changes nothing."""
    grow = hull_growth(limits)
    if (
        grow == 0.0
        and limits.max_speed_m_s == spec.max_speed_m_s
        and limits.min_brake_m_s2 == spec.max_accel_m_s2
    ):
        return spec
    return VehicleSpec(
        spec.length_m + 2 * grow,
        spec.width_m + 2 * grow,
        limits.max_speed_m_s,
        limits.min_brake_m_s2,
        spec.battery,
    )


class DrivenVehicle:
    """A vehicle behind a driver, as the controller sees it (the module docstring).

    Args:
        driver: the vehicle's driver, with its first pose report queued; the vehicle
            stands.
        spec: the vehicle's own size and limits.
        clock: the controller's clock.

    Raises:
        ValueError: the driver has reported no pose, or the vehicle moves.
    """

    __slots__ = (
        "_asked",
        "_c",
        "_clock",
        "_error",
        "_heard",
        "_off_route_m",
        "_pose",
        "_route",
        "_s",
        "_short",
        "_since",
        "_speed",
        "_started",
        "_tolerance",
        "driver",
        "fault",
        "hard_stops",
        "late_reports",
        "limits",
        "spec",
    )

    def __init__(
        self, driver: VehicleDriver, spec: VehicleSpec, *, clock: Callable[[], float]
    ) -> None:
        self.driver = driver
        self.limits = limits = driver.limits
        self.spec = planning_spec(spec, limits)
        self.hard_stops = 0
        """How many times a limit was pulled back behind where the vehicle could stop."""
        self.fault: str | None = None
        """Why the vehicle counts as failed (None: it does not)."""
        self.late_reports = 0
        """Reports dropped as older than one heard before them."""
        self._clock = clock
        self._error = limits.localization_error_m
        self._c = brake_margin_factor(limits)
        self._tolerance = hull_growth(limits)
        self._off_route_m = 3.0 * self._error + 1e-6
        self._short = False
        reports = [e.report for e in driver.events() if isinstance(e, PoseReported)]
        if not reports:
            raise ValueError("the driver has reported no pose: where does the vehicle stand?")
        first = max(reports, key=lambda r: r.t)
        if first.speed_m_s != 0.0:
            raise ValueError(f"the vehicle moves ({first.speed_m_s!r} m/s): it must stand")
        self._route = Polyline([(first.x, first.y)], heading_rad=first.heading_rad)
        self._s = 0.0
        self._pose: Pose | None = None
        self._speed = 0.0
        self._asked = 0.0
        now = clock()
        self._heard = first.t
        self._started = now
        self._since = now

    # -- state --------------------------------------------------------------------

    @property
    def route(self) -> Polyline:
        """The polyline the vehicle follows."""
        return self._route

    @property
    def s(self) -> float:
        """Arc length the vehicle has driven along the route at least, metres."""
        return self._s

    @property
    def speed(self) -> float:
        """Its last reported speed, m/s."""
        return self._speed

    @property
    def arrived(self) -> bool:
        """True when at the end of the route and at rest."""
        return self._s >= self._route.length and self._speed == 0.0

    def remaining(self) -> float:
        """Distance left to the end of the route, metres."""
        return self._route.length - self._s

    def stopping_s(self) -> float:
        """Arc length where the vehicle comes to rest at the latest, braking now."""
        return self._s + self.spec.braking_distance(self._speed)

    def pose(self) -> Pose:
        """Where it stands on its route (on a vertex: facing the way it arrived)."""
        pose = self._pose
        if pose is None:
            pose = self._pose = self._route.pose_at(self._s)
        return pose

    def hull(self) -> Area:
        """The hull the traffic control plans with, where the vehicle stands."""
        return hull(self.pose(), length=self.spec.length_m, width=self.spec.width_m)

    # -- commands -------------------------------------------------------------------

    def new_route(self, route: Polyline, *, s: float = 0.0) -> None:
        """Follow ``route`` from arc length ``s``; only while standing.

        Raises:
            ValueError: the vehicle moves, or ``s`` lies outside ``route``.
        """
        if self._speed != 0.0:
            raise ValueError(f"cannot change route at speed {self._speed!r} m/s")
        if not 0.0 <= s <= route.length:
            raise ValueError(f"start s={s!r} outside route of length {route.length!r}")
        if route.length == 0.0 and len(route.coords) == 1:
            # Keep facing the way we were when told to stand somewhere.
            route = Polyline(route.coords, heading_rad=self.pose().heading_rad)
        self.driver.follow(route, s=s)
        self._route = route
        self._s = float(s)
        self._pose = None
        self._asked = self._s
        self._since = self._clock()

    def shorten_route(self, length: float) -> None:
        """End the route at arc length ``length``, not behind the vehicle.

        Raises:
            ValueError: ``length`` lies behind the vehicle or beyond the route's end.
        """
        if not self._s <= length <= self._route.length:
            raise ValueError(
                f"cannot end the route at s={length!r}: the vehicle is at {self._s!r}, "
                f"the route {self._route.length!r} long"
            )
        self.driver.shorten(length)
        self._route = self._route.slice(0.0, length)
        self._pose = None

    def step(self, dt: float, limit_s: float) -> float:
        """Let the vehicle drive ``dt`` seconds, not past ``limit_s`` (the end of its
        locks); return how far ``s`` moved."""
        self._take(self.driver.events())  # what came in since the last tick
        s0 = self._s
        pulled_back = limit_s + _SLACK_M < min(self._asked, self.stopping_s())
        if pulled_back and not self._short:
            self.hard_stops += 1
        self._short = pulled_back
        self._asked = limit_s
        self.driver.drive(self._limit_for(limit_s, dt))
        self._tick(dt)
        return self._s - s0

    def stand(self, dt: float) -> None:
        """Let ``dt`` seconds pass with the vehicle standing where it is."""
        self._asked = self._s
        self.driver.drive(self._limit_for(self._s, dt))
        self._tick(dt)

    def coast(self, dt: float) -> None:
        """Let ``dt`` seconds pass under the last command (a stop, once failed)."""
        self._tick(dt)

    def stop(self) -> None:
        """Brake to a standstill now (the simulated vehicle stops dead)."""
        self.driver.stop()
        self._take(self.driver.events())

    def clear_fault(self) -> None:
        """Count the vehicle as sound again (its controller restarts); silence counts
        from now."""
        self.fault = None
        self._started = self._clock()

    def adopt(self, vehicle: Vehicle) -> None:
        """Go on with ``vehicle`` as the simulated kinematics (a simulation that sets
        them itself).

        Raises:
            TypeError: the driver is no :class:`~agv_app.vehicle.sim_driver.SimDriver`.
        """
        driver = self.driver
        if not isinstance(driver, SimDriver):
            raise TypeError(f"only a simulated vehicle takes new kinematics, not {driver!r}")
        driver.adopt(vehicle)
        driver.events()
        self._route = vehicle.route
        self._s = vehicle.s
        self._speed = vehicle.speed
        self._pose = None

    # -- what the driver says --------------------------------------------------------

    def _limit_for(self, limit_s: float, dt: float) -> float:
        """The limit to give the driver for the end of the locks at ``limit_s``."""
        c = self._c
        if c == 0.0:
            return limit_s
        limits = self.limits
        age = max(0.0, self._clock() - self._heard) + dt
        v = min(limits.max_speed_m_s, self._speed + limits.accel_m_s2 * age)
        return min(limit_s, self._route.length) - c * v * v

    def _tick(self, dt: float) -> None:
        now = self._clock()
        driver = self.driver
        driver.tick(dt, now=now)
        events = driver.events()
        if events:
            self._take(events)
        if self.fault is not None:
            return
        timeout = self.limits.report_timeout_s
        if timeout is not None and now - max(self._heard, self._started) > timeout:
            self._fail(f"no pose report for {now - max(self._heard, self._started):.1f} s")
            return
        length = self._route.length
        if (
            self._tolerance > 0.0
            and self._speed == 0.0
            and self._asked >= length - 1e-9
            and length - self._s <= self._tolerance
        ):
            self._s = length  # it stands as close to the end as it comes: arrived
            self._pose = None

    def _take(self, events: Sequence[DriverEvent]) -> None:
        for event in events:
            if isinstance(event, PoseReported):
                self._heard_report(event.report)
            elif isinstance(event, Stopped):
                if event.t >= self._heard:
                    self._speed = 0.0
            else:
                self._fail(f"the driver failed: {event.reason}")

    def _heard_report(self, report: PoseReport) -> None:
        if report.t < self._heard or report.t < self._since:
            self.late_reports += 1
            return  # older than what we know, or of a route before this one
        self._heard = report.t
        self._speed = report.speed_m_s
        error = self._error
        if error == 0.0:
            # An exact driver's report is where the vehicle is (the simulated one's is
            # its route's pose at ``s``): nothing to check it against.
            if report.s > self._s:
                self._s = report.s
                self._pose = Pose(report.x, report.y, report.heading_rad)
            return
        x, y = self._route.point_at(report.s)
        if math.hypot(report.x - x, report.y - y) > self._off_route_m:
            self._fail(
                f"reported ({report.x:.3f}, {report.y:.3f}), off its route at s={report.s:.3f}"
            )
            return
        s = report.s - error
        if s > self._s:
            self._s = min(s, self._route.length)
            self._pose = None

    def _fail(self, reason: str) -> None:
        if self.fault is None:
            self.fault = reason
            self.driver.stop()
