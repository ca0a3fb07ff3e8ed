"""The vehicle as the controller knows it through a driver: what it believes of the
reports, the limit it gives, and when it counts the vehicle as failed."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from agv_app.geometry import Polyline, Pose
from agv_app.vehicle import (
    DrivenVehicle,
    DriverEvent,
    DriverFault,
    DriverLimits,
    PoseReport,
    PoseReported,
    SimDriver,
    VehicleSpec,
    planning_spec,
)
from agv_app.vehicle.driven import brake_margin_factor, hull_growth
from agv_app.vehicle.state_file import StateFile, StateFileError

SPEC = VehicleSpec(2.0, 1.0, 1.5, 0.5)
LANE = Polyline([(0.0, 0.0), (50.0, 0.0)])


class Scripted:
    """A driver whose reports a test writes; it records the commands."""

    def __init__(self, limits: DriverLimits) -> None:
        self.limits = limits
        self.queue: list[DriverEvent] = [PoseReported(PoseReport(0.0, 0.0, 0.0, 0.0, 0.0, 0.0))]
        self.limit_s: float | None = None
        self.stops = 0

    def follow(self, route: Polyline, *, s: float) -> None:
        pass

    def shorten(self, length: float) -> None:
        pass

    def drive(self, limit_s: float) -> None:
        self.limit_s = limit_s

    def stop(self) -> None:
        self.stops += 1

    def tick(self, dt: float, *, now: float) -> None:
        pass

    def events(self) -> list[DriverEvent]:
        out, self.queue = self.queue, []
        return out

    def report(self, s: float, *, t: float, speed: float = 1.0, off: float = 0.0) -> None:
        self.queue.append(PoseReported(PoseReport(s, off, 0.0, t, speed, s)))


def noisy(error_m: float = 0.05, min_brake: float = 0.4) -> DriverLimits:
    return DriverLimits(1.5, 0.5, 0.5, min_brake, error_m, 1.0)


def driven(limits: DriverLimits) -> tuple[DrivenVehicle, Scripted, list[float]]:
    clock = [0.0]
    driver = Scripted(limits)
    vehicle = DrivenVehicle(driver, SPEC, clock=lambda: clock[0])
    vehicle.new_route(LANE, s=0.0)
    return vehicle, driver, clock


def test_the_simulated_driver_changes_nothing_the_controller_plans_with() -> None:
    driver = SimDriver(SPEC, Pose(0.0, 0.0, 0.0))
    assert planning_spec(SPEC, driver.limits) is SPEC
    vehicle = DrivenVehicle(driver, SPEC, clock=lambda: 0.0)
    vehicle.new_route(LANE)
    moved = vehicle.step(0.1, 20.0)
    kinematics = driver.vehicle
    assert (vehicle.s, vehicle.speed, moved) == (kinematics.s, kinematics.speed, kinematics.s)
    assert vehicle.pose() == kinematics.pose()
    assert vehicle.hull() is kinematics.hull()


def test_the_declared_error_and_a_brake_that_may_fall_short_grow_the_hull() -> None:
    limits = noisy()
    c = brake_margin_factor(limits)
    assert c == pytest.approx(0.25)  # (1/0.4 - 1/0.5) / 2
    # Twice the error, and the margin at rest with the oldest report not yet a fault.
    assert hull_growth(limits) == pytest.approx(0.1 + c * (0.5 * 1.2) ** 2)
    plan = planning_spec(SPEC, limits)
    assert plan.length_m == pytest.approx(2.0 + 2 * hull_growth(limits))
    assert plan.width_m == pytest.approx(1.0 + 2 * hull_growth(limits))
    assert plan.braking_distance(1.5) == pytest.approx(1.5**2 / 0.8)


def test_progress_is_a_lower_bound_and_older_reports_are_dropped() -> None:
    vehicle, driver, clock = driven(noisy())
    clock[0] = 1.0
    driver.report(10.0, t=0.9)
    vehicle.step(0.1, 30.0)
    assert vehicle.s == pytest.approx(9.95)
    driver.report(9.0, t=0.95)  # a newer report, a little behind: noise
    driver.report(12.0, t=0.5)  # late: older than the one heard
    vehicle.step(0.1, 30.0)
    assert vehicle.s == pytest.approx(9.95)
    assert vehicle.late_reports == 1


def test_the_limit_keeps_the_floor_a_weak_brake_needs_at_the_speed_it_may_have() -> None:
    vehicle, driver, clock = driven(noisy())
    clock[0] = 2.0
    driver.report(10.0, t=1.8, speed=1.0)
    vehicle.step(0.1, 30.0)
    # Reported 1.0 m/s 0.2 s before, 0.1 s to the next command: at most 1.15 m/s.
    v_b = 1.0 + 0.5 * (0.2 + 0.1)
    assert driver.limit_s == pytest.approx(30.0 - 0.25 * v_b**2)
    # Reported from far back, it may go at full speed: the largest margin.
    clock[0] = 4.0
    vehicle.step(0.1, 30.0)
    assert driver.limit_s == pytest.approx(30.0 - 0.25 * 1.5**2)


def test_the_limit_is_the_lock_end_when_the_brake_is_as_planned() -> None:
    vehicle, driver, _clock = driven(noisy(min_brake=0.5))
    vehicle.step(0.1, 17.25)
    assert driver.limit_s == 17.25


def test_a_vehicle_silent_past_its_timeout_is_stopped_and_counts_as_failed() -> None:
    vehicle, driver, clock = driven(noisy())
    clock[0] = 0.9
    driver.report(1.0, t=0.9)
    vehicle.step(0.1, 30.0)
    clock[0] = 1.9
    vehicle.step(0.1, 30.0)
    assert vehicle.fault is None
    clock[0] = 2.0
    vehicle.step(0.1, 30.0)
    assert vehicle.fault == "no pose report for 1.1 s"
    assert driver.stops == 1
    vehicle.clear_fault()
    assert vehicle.fault is None


def test_a_report_off_the_route_or_a_fault_of_the_driver_is_a_fault() -> None:
    vehicle, driver, _clock = driven(noisy())
    driver.report(5.0, t=0.0, off=0.16)  # three times the error is 0.15
    vehicle.step(0.1, 30.0)
    assert vehicle.fault is not None
    assert vehicle.fault.startswith("reported (5.000, 0.160), off its route")
    other, driver2, _ = driven(noisy())
    driver2.queue.append(DriverFault(0.0, "emergency stop pressed"))
    other.step(0.1, 30.0)
    assert other.fault == "the driver failed: emergency stop pressed"


def test_arrived_when_it_stands_within_the_hull_growth_of_the_end() -> None:
    vehicle, driver, _clock = driven(noisy())
    short = 50.0 - hull_growth(noisy()) + 0.01
    driver.report(short + 0.05, t=0.0, speed=0.0)
    vehicle.step(0.1, 49.0)
    assert vehicle.s == pytest.approx(short)  # not asked to the end: where it is
    vehicle.step(0.1, 50.0)
    assert vehicle.arrived


def test_declared_limits_are_checked() -> None:
    with pytest.raises(ValueError, match="min_brake_m_s2"):
        DriverLimits(1.5, 0.5, 0.5, 0.6)
    with pytest.raises(ValueError, match="report_timeout_s"):
        DriverLimits(1.5, 0.5, 0.5, 0.4, 0.05)
    with pytest.raises(ValueError, match="localization_error_m"):
        DriverLimits(1.5, 0.5, 0.5, 0.5, -0.1)
    moving = Scripted(noisy())
    moving.queue = [PoseReported(PoseReport(0.0, 0.0, 0.0, 0.0, 0.3, 0.0))]
    with pytest.raises(ValueError, match="stand"):
        DrivenVehicle(moving, SPEC, clock=lambda: 0.0)


def test_the_simulated_driver_keeps_its_pose_in_a_state_file(tmp_path: Path) -> None:
    state = StateFile(tmp_path / "agv-01.pose.json")
    driver = SimDriver(SPEC, Pose(0.0, 0.0, 0.0), state=state)
    vehicle = DrivenVehicle(driver, SPEC, clock=lambda: 0.0)
    vehicle.new_route(LANE)
    for _ in range(30):
        vehicle.step(0.1, 50.0)
    stood = vehicle.pose()
    again = SimDriver.recovered(SPEC, state, default=Pose(9.0, 9.0, 0.0))
    first = again.events()[0]
    assert isinstance(first, PoseReported)
    assert (first.report.x, first.report.y) == (stood.x, stood.y)
    assert not list(tmp_path.glob(".*.tmp"))  # replaced, not left behind


def test_a_state_file_that_is_no_json_or_holds_no_pose_is_refused(tmp_path: Path) -> None:
    state = StateFile(tmp_path / "x.json")
    assert state.read() is None
    state.path.write_text("{")
    with pytest.raises(StateFileError, match="not JSON"):
        state.read()
    state.write({"x": 1.0, "y": math.inf})
    with pytest.raises(StateFileError, match="finite"):
        SimDriver.recovered(SPEC, state, default=Pose(0.0, 0.0, 0.0))


def test_a_limit_pulled_back_behind_where_the_vehicle_can_stop_counts_once() -> None:
    vehicle, driver, _clock = driven(noisy(min_brake=0.5))
    driver.report(10.0, t=0.0, speed=1.5)  # it stops 2.25 m on at the earliest
    vehicle.step(0.1, 30.0)
    vehicle.step(0.1, 11.0)
    vehicle.step(0.1, 11.0)
    assert vehicle.hard_stops == 1
