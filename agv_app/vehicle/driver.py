"""The driver interface: how the traffic control talks to a vehicle's motion.

A vehicle's motion sits behind a :class:`VehicleDriver`. What goes in (from the
vehicle) is pose reports, stop events and faults; what goes out (to the vehicle) is a
route and how far along it the vehicle may drive. The controller talks to the vehicle
through nothing else, so the simulated kinematics
(:class:`~agv_app.vehicle.sim_driver.SimDriver`, the default) and a real vehicle are
interchangeable. docs/drivers.md says how to write one.

The contract, in the controller's words:

* ``follow(route, s=...)``: drive along ``route`` (a polyline on the floor) from arc
  length ``s``, where the vehicle stands; given only while it stands.
* ``drive(limit_s)``: the vehicle may drive along the route up to arc length
  ``limit_s`` and must come to rest at or before it, braking with its declared
  ``brake_m_s2``; each call replaces the last. A limit behind where the vehicle can
  still stop means: brake now.
* ``stop()``: brake to a standstill now and stay until the next ``drive``.
* ``tick(dt, now=...)``: ``dt`` seconds passed; ``now`` is the controller's clock,
  the one the driver stamps its reports with.
* ``events()``: what the vehicle said since the last call, oldest first.

What a driver declares (:class:`DriverLimits`) is what the traffic control plans with:
its braking distances use the least deceleration the brake achieves, the floor it keeps
between the vehicle's limit and the end of its locks covers a brake that falls short of
what the vehicle plans with, and the hull it projects is grown by the localization
error (:mod:`agv_app.vehicle.driven`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from agv_app.geometry import Polyline

__all__ = [
    "DriverEvent",
    "DriverFault",
    "DriverLimits",
    "PoseReport",
    "PoseReported",
    "Stopped",
    "VehicleDriver",
]


@dataclass(frozen=True, slots=True)
class DriverLimits:
    """What a driver declares about its vehicle (metres, seconds).

    Attributes:
        max_speed_m_s: top speed.
        accel_m_s2: acceleration.
        brake_m_s2: the deceleration the vehicle plans its stops with (its service
            brake): it starts braking where this stops it at its limit.
        min_brake_m_s2: the least deceleration its brake achieves (a full load, a wet
            floor), at most ``brake_m_s2``; the controller keeps the difference in
            stopping distance as floor between the limit it gives and its locks' end.
        localization_error_m: how far the vehicle may truly stand from where its
            reports put it, along its route (``PoseReport.s``) and off it (any point of
            its hull, path following included), and how close to a limit it comes to
            rest.
        report_timeout_s: a healthy vehicle reports its pose at least this often; a
            longer silence counts as a fault (None: the driver never goes silent, as
            the simulated one). Needed when the brake may fall short: the speed the
            margin allows for grows with the age of the last report.
    """

    max_speed_m_s: float
    accel_m_s2: float
    brake_m_s2: float
    min_brake_m_s2: float
    localization_error_m: float = 0.0
    report_timeout_s: float | None = None

    def __post_init__(self) -> None:
        for name in ("max_speed_m_s", "accel_m_s2", "brake_m_s2", "min_brake_m_s2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"DriverLimits.{name} must be positive and finite, got {value!r}")
        if self.min_brake_m_s2 > self.brake_m_s2:
            raise ValueError(
                f"min_brake_m_s2 {self.min_brake_m_s2!r} above brake_m_s2 {self.brake_m_s2!r}"
            )
        error = self.localization_error_m
        if not (math.isfinite(error) and error >= 0):
            raise ValueError(f"localization_error_m must be >= 0 and finite, got {error!r}")
        timeout = self.report_timeout_s
        if timeout is not None and not (math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"report_timeout_s must be positive, got {timeout!r}")
        if self.min_brake_m_s2 < self.brake_m_s2 and timeout is None:
            raise ValueError("a brake that may fall short needs a report_timeout_s")


@dataclass(frozen=True, slots=True)
class PoseReport:
    """Where the vehicle was, by its own measure.

    Attributes:
        x: metres.
        y: metres.
        heading_rad: radians (0 = +x).
        t: when it was measured, on the controller's clock (the ``now`` of ``tick``).
        speed_m_s: its speed then (never negative).
        s: arc length along the route it follows (``follow``): a vehicle that follows a
            path knows how far along it is (VDA 5050 reports it as the last node passed
            and the distance since); it carries the localization error too.
    """

    x: float
    y: float
    heading_rad: float
    t: float
    speed_m_s: float
    s: float


@dataclass(frozen=True, slots=True)
class PoseReported:
    """The vehicle reported its pose (reports may come late, out of order, or never)."""

    report: PoseReport


@dataclass(frozen=True, slots=True)
class Stopped:
    """The vehicle came to rest (measured at ``t``)."""

    t: float


@dataclass(frozen=True, slots=True)
class DriverFault:
    """The vehicle, or the link to it, failed; it is braking if it can."""

    t: float
    reason: str


DriverEvent = PoseReported | Stopped | DriverFault
"""What a driver reports."""


class VehicleDriver(Protocol):
    """A vehicle's motion, as the traffic control sees it (the module docstring has the
    contract). A driver is handed to the controller with a first pose report queued:
    where the vehicle stands."""

    @property
    def limits(self) -> DriverLimits:
        """What the driver declares."""
        ...

    def follow(self, route: Polyline, *, s: float) -> None:
        """Drive along ``route`` from arc length ``s`` (given while standing)."""
        ...

    def shorten(self, length: float) -> None:
        """End the route at arc length ``length``; the path up to there stays the same."""
        ...

    def drive(self, limit_s: float) -> None:
        """Drive along the route, coming to rest at or before arc length ``limit_s``."""
        ...

    def stop(self) -> None:
        """Brake to a standstill now, and stand until the next ``drive``."""
        ...

    def tick(self, dt: float, *, now: float) -> None:
        """``dt`` seconds have passed; it is ``now`` on the controller's clock."""
        ...

    def events(self) -> Sequence[DriverEvent]:
        """What the vehicle reported since the last call, oldest first."""
        ...
