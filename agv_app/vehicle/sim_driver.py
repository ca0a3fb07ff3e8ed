"""The simulated vehicle behind the driver interface: the kinematics of
:class:`~agv_app.vehicle.kinematics.Vehicle`, the default driver.

It reports its arc length along the route with every pose, exactly, and only when
something changed (a standing vehicle says nothing, and is never silent too long: it
declares no report timeout). Its brake is what it declares, its position exact, so the
controller plans with the vehicle's own figures and every seeded simulation runs as it
did before drivers existed. ``stop()`` stops it dead where it stands: the simulation's
model of a crash, which the kinematics never brake through.

Given a :class:`~agv_app.vehicle.state_file.StateFile`, it keeps its pose there, written
in the same tick the pose changes and before the controller hears of it, so a process
restarted on the same host finds the simulated vehicle where it stood
(:meth:`SimDriver.recovered`).
"""

from __future__ import annotations

from collections.abc import Sequence

from agv_app.geometry import Area, Polyline, Pose
from agv_app.vehicle.driver import DriverEvent, DriverLimits, PoseReport, PoseReported, Stopped
from agv_app.vehicle.kinematics import Vehicle, VehicleSpec
from agv_app.vehicle.state_file import StateFile, pose_from_json, pose_to_json

__all__ = ["SimDriver"]


class SimDriver:
    """The simulated kinematics as a :class:`~agv_app.vehicle.driver.VehicleDriver`.

    Args:
        spec: the vehicle's size and limits.
        pose: where it stands, at rest.
        state: where it keeps its pose (None: nowhere).
    """

    __slots__ = ("_events", "_kept", "_limit", "_now", "_state", "_vehicle", "limits", "spec")

    def __init__(self, spec: VehicleSpec, pose: Pose, *, state: StateFile | None = None) -> None:
        self.spec = spec
        a = spec.max_accel_m_s2
        self.limits = DriverLimits(spec.max_speed_m_s, a, a, a)
        self._vehicle = Vehicle.parked(spec, pose)
        self._limit = 0.0
        self._now = 0.0
        self._state = state
        self._kept: Pose | None = None
        self._events: list[DriverEvent] = [PoseReported(self._report())]
        self._keep()

    @classmethod
    def recovered(cls, spec: VehicleSpec, state: StateFile, *, default: Pose) -> SimDriver:
        """The simulated vehicle where its state file says it stands, else at ``default``.

        Raises:
            StateFileError: the file holds no pose.
        """
        document = state.read()
        pose = default if document is None else pose_from_json(document, where=str(state.path))
        return cls(spec, pose, state=state)

    # -- the driver interface -------------------------------------------------------

    def follow(self, route: Polyline, *, s: float) -> None:
        """Drive along ``route`` from ``s`` (see ``Vehicle.new_route``)."""
        self._vehicle.new_route(route, s=s)

    def shorten(self, length: float) -> None:
        """End the route at ``length`` (see ``Vehicle.shorten_route``)."""
        self._vehicle.shorten_route(length)

    def drive(self, limit_s: float) -> None:
        """Drive up to ``limit_s`` from the next tick on."""
        self._limit = limit_s

    def stop(self) -> None:
        """Stop dead where it stands (a crash: the simulation cuts its motion)."""
        vehicle = self._vehicle
        moving = vehicle.speed > 0.0
        self._vehicle = Vehicle(self.spec, vehicle.route, s=vehicle.s)
        self._limit = vehicle.s
        if moving:
            self._events.append(PoseReported(self._report()))
            self._events.append(Stopped(self._now))

    def tick(self, dt: float, *, now: float) -> None:
        """Move ``dt`` seconds towards the limit; report if the vehicle moved."""
        self._now = now
        vehicle = self._vehicle
        was = vehicle.speed
        if was == 0.0 and self._limit <= vehicle.s:
            return  # standing, and told to stand: the kinematics would not move
        if vehicle.step(dt, self._limit) == 0.0 and vehicle.speed == was:
            return
        self._keep()
        self._events.append(PoseReported(self._report()))
        if was > 0.0 and vehicle.speed == 0.0:
            self._events.append(Stopped(now))

    def events(self) -> Sequence[DriverEvent]:
        """What happened since the last call."""
        if not self._events:
            return ()
        out, self._events = self._events, []
        return out

    # -- the simulation's own -------------------------------------------------------

    @property
    def vehicle(self) -> Vehicle:
        """The kinematics (the simulation's ground truth)."""
        return self._vehicle

    def adopt(self, vehicle: Vehicle) -> None:
        """Go on with ``vehicle`` as the kinematics (a simulation that set them itself)."""
        self._vehicle = vehicle
        self._limit = min(self._limit, vehicle.route.length)
        self._events.append(PoseReported(self._report()))

    def true_hull(self) -> Area:
        """Where the vehicle truly stands."""
        return self._vehicle.hull()

    def _report(self) -> PoseReport:
        vehicle = self._vehicle
        pose = vehicle.pose()
        return PoseReport(pose.x, pose.y, pose.heading_rad, self._now, vehicle.speed, vehicle.s)

    def _keep(self) -> None:
        """Write the pose to the state file if it changed."""
        if self._state is None:
            return
        pose = self._vehicle.pose()
        if pose != self._kept:
            # Durable only at rest: a power cut while it drives may cost the last writes.
            self._state.write(pose_to_json(pose), durable=self._vehicle.speed == 0.0)
            self._kept = pose
