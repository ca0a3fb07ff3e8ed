"""Vehicle kinematics: a rectangle that drives along a polyline, never past its lock.

Pure and deterministic: no clock, no middleware. The driver calls
``step(dt, limit_s)`` once per simulation step, where ``limit_s`` is the arc
length up to which the vehicle's locked area reaches; the vehicle accelerates,
cruises or brakes (deceleration limit = ``max_accel_m_s2``) so that it

* never passes ``limit_s``, and
* can always still stop at or before ``limit_s``, so it reaches the limit
  exactly and at rest when the limit does not move.

Within a step the motion is the time-optimal one towards a stop at the limit
(accelerate, cruise at ``max_speed_m_s``, brake), integrated in closed form, so
the result does not depend on how the time is cut into steps, apart from where
the limit changes. If the limit is pulled back behind where the vehicle can stop
(which a correct lock protocol never does), the vehicle brakes fully and, should
that not suffice, stops dead at the limit; :attr:`Vehicle.hard_stops` counts
those events so a simulation can report them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from agv_app.geometry import Area, Polyline, Pose, hull
from agv_app.vehicle.battery import BatterySpec

__all__ = ["Vehicle", "VehicleSpec"]

_SLACK_M = 1e-9  # rounding noise tolerated when checking the braking envelope


@dataclass(frozen=True, slots=True)
class VehicleSpec:
    """Size and limits of a vehicle type.

    Attributes:
        length_m: hull extent along the heading.
        width_m: hull extent across the heading.
        max_speed_m_s: top speed.
        max_accel_m_s2: acceleration limit, also used for braking.
        battery: its battery (None: no battery model; it never runs empty).
    """

    length_m: float = 2.0
    width_m: float = 1.0
    max_speed_m_s: float = 1.5
    max_accel_m_s2: float = 0.5
    battery: BatterySpec | None = None

    def __post_init__(self) -> None:
        for name in ("length_m", "width_m", "max_speed_m_s", "max_accel_m_s2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"VehicleSpec.{name} must be positive and finite, got {value!r}")

    def braking_distance(self, speed_m_s: float) -> float:
        """Distance in metres needed to stop from ``speed_m_s`` at full braking."""
        return speed_m_s * speed_m_s / (2 * self.max_accel_m_s2)

    def travel_time(self, distance_m: float) -> float:
        """Shortest time in seconds to drive ``distance_m`` from rest to rest."""
        if distance_m <= 0:
            return 0.0
        a, v = self.max_accel_m_s2, self.max_speed_m_s
        ramp = v * v / a  # distance spent accelerating to top speed and braking from it
        if distance_m <= ramp:
            return 2 * math.sqrt(distance_m / a)
        return 2 * v / a + (distance_m - ramp) / v


class Vehicle:
    """A vehicle driving along a polyline route.

    Args:
        spec: size and limits.
        route: the polyline to follow (a one-vertex polyline: standing still).
        s: starting arc length along ``route``.
        speed_m_s: starting speed.

    Raises:
        ValueError: ``s`` outside the route or a speed outside ``[0, max_speed]``.
    """

    __slots__ = ("_route", "_s", "_speed", "hard_stops", "spec")

    def __init__(
        self, spec: VehicleSpec, route: Polyline, *, s: float = 0.0, speed_m_s: float = 0.0
    ) -> None:
        self.spec = spec
        self.hard_stops = 0
        """How many times a pulled-back limit forced a stop no brake could make."""
        if not 0.0 <= s <= route.length:
            raise ValueError(f"start s={s!r} outside route of length {route.length!r}")
        if not 0.0 <= speed_m_s <= spec.max_speed_m_s:
            raise ValueError(f"speed {speed_m_s!r} outside [0, {spec.max_speed_m_s!r}]")
        self._route = route
        self._s = float(s)
        self._speed = float(speed_m_s)

    @classmethod
    def parked(cls, spec: VehicleSpec, pose: Pose) -> Vehicle:
        """A vehicle standing still at ``pose`` with no route."""
        return cls(spec, Polyline([(pose.x, pose.y)], heading_rad=pose.heading_rad))

    # -- state --------------------------------------------------------------------

    @property
    def route(self) -> Polyline:
        """The polyline being followed."""
        return self._route

    @property
    def s(self) -> float:
        """Arc length driven along the route, metres."""
        return self._s

    @property
    def speed(self) -> float:
        """Current speed, m/s (never negative)."""
        return self._speed

    @property
    def arrived(self) -> bool:
        """True when at the end of the route and at rest."""
        return self._s >= self._route.length and self._speed == 0.0

    def remaining(self) -> float:
        """Distance left to the end of the route, metres."""
        return self._route.length - self._s

    def stopping_s(self) -> float:
        """Arc length where the vehicle would come to rest braking fully now."""
        return self._s + self.spec.braking_distance(self._speed)

    def pose(self) -> Pose:
        """Position and heading now (on a vertex: the heading it arrived with)."""
        return self._route.pose_at(self._s)

    def hull(self) -> Area:
        """The vehicle's rectangle now."""
        return hull(self.pose(), length=self.spec.length_m, width=self.spec.width_m)

    def new_route(self, route: Polyline, *, s: float = 0.0) -> None:
        """Start following ``route`` from arc length ``s``; only while standing still.

        Raises:
            ValueError: the vehicle is moving, or ``s`` lies outside ``route``.
        """
        if self._speed != 0.0:
            raise ValueError(f"cannot change route at speed {self._speed!r} m/s")
        if not 0.0 <= s <= route.length:
            raise ValueError(f"start s={s!r} outside route of length {route.length!r}")
        if route.length == 0.0 and len(route.coords) == 1:
            # Keep facing the way we were when told to stand somewhere.
            route = Polyline(route.coords, heading_rad=self.pose().heading_rad)
        self._route = route
        self._s = float(s)

    def shorten_route(self, length: float) -> None:
        """End the route at arc length ``length``, not behind the vehicle (it may move):
        the path up to there stays the same.

        Raises:
            ValueError: ``length`` lies behind the vehicle or beyond the route's end.
        """
        if not self._s <= length <= self._route.length:
            raise ValueError(
                f"cannot end the route at s={length!r}: the vehicle is at {self._s!r}, "
                f"the route {self._route.length!r} long"
            )
        self._route = self._route.slice(0.0, length)

    # -- motion -------------------------------------------------------------------

    def step(self, dt: float, limit_s: float) -> float:
        """Advance ``dt`` seconds without passing ``limit_s``; return the distance moved.

        ``limit_s`` is clamped to the route's end. The vehicle never moves
        backwards.

        Raises:
            ValueError: negative or non-finite ``dt``, or a NaN limit.
        """
        if not (math.isfinite(dt) and dt >= 0):
            raise ValueError(f"dt must be finite and >= 0, got {dt!r}")
        if math.isnan(limit_s):
            raise ValueError("limit_s is NaN")
        limit = min(limit_s, self._route.length)
        s0 = self._s
        if dt == 0.0:
            return 0.0
        a = self.spec.max_accel_m_s2
        v = self._speed
        room = limit - s0
        if room < 0.0 or self.spec.braking_distance(v) > room + _SLACK_M:
            self._brake(dt, limit)
        else:
            self._s, self._speed = _drive(s0, v, dt, limit, a, self.spec.max_speed_m_s)
        return self._s - s0

    def _brake(self, dt: float, limit: float) -> None:
        a = self.spec.max_accel_m_s2
        v = self._speed
        if v <= a * dt:
            s1, v1 = self._s + v * v / (2 * a), 0.0
        else:
            s1, v1 = self._s + v * dt - a * dt * dt / 2, v - a * dt
        if s1 > max(self._s, limit):
            if s1 > limit + _SLACK_M:
                self.hard_stops += 1
            s1, v1 = max(self._s, limit), 0.0
        self._s, self._speed = s1, v1


def _drive(
    s: float, v: float, dt: float, limit: float, a: float, vmax: float
) -> tuple[float, float]:
    """Time-optimal motion towards a stop at ``limit``, advanced by ``dt``.

    Precondition: ``s + v²/2a <= limit``. Phases: accelerate to the peak speed,
    cruise, brake to rest exactly at ``limit``.
    """
    v = min(v, vmax)
    d = limit - s
    peak = min(vmax, math.sqrt(max(a * d + v * v / 2, v * v)))
    t1 = (peak - v) / a
    d1 = (peak * peak - v * v) / (2 * a)
    d3 = peak * peak / (2 * a)
    d2 = max(0.0, d - d1 - d3)
    t2 = d2 / peak if peak > 0 else 0.0
    t3 = peak / a
    if dt >= t1 + t2 + t3:
        return limit, 0.0
    if dt <= t1:
        s1 = s + v * dt + a * dt * dt / 2
        v1 = v + a * dt
    elif dt <= t1 + t2:
        s1 = s + d1 + peak * (dt - t1)
        v1 = peak
    else:
        tb = dt - t1 - t2
        v1 = max(0.0, peak - a * tb)
        s1 = s + d1 + d2 + (peak + v1) / 2 * tb
    return min(s1, limit), v1
