"""An AGV process with a state directory comes back where its vehicle stands."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from agv_app.fleet import agv_process
from agv_app.fleet.restart_state import TaskKeeper, held_task, vehicle_driver
from agv_app.geometry import Pose
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.tasks.auction import TaskSpec
from agv_app.vehicle import PoseReported, SimDriver, VehicleSpec
from agv_app.vehicle.standin import StandInDriver
from agv_app.vehicle.state_file import StateFile, StateFileError
from tests.credentials import write_secret

SPEC = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
HOME = Pose(3.5, 39.0, -math.pi / 2)
ARGS = ["--id", "agv-01", "--pki", "pki", "--home", "P0350n"]


def test_the_driver_and_the_state_dir_are_options(tmp_path: Path) -> None:
    plain = agv_process.parse_args(ARGS)
    assert (plain.driver, plain.state_dir) == ("sim", None)
    assert vehicle_driver(plain, SPEC, HOME) is None  # the controller builds its own
    assert held_task(plain) is None
    args = agv_process.parse_args([*ARGS, "--driver", "standin", "--state-dir", str(tmp_path)])
    assert isinstance(vehicle_driver(args, SPEC, HOME), StandInDriver)
    with pytest.raises(SystemExit):
        agv_process.parse_args([*ARGS, "--driver", "tractor"])


def test_the_state_dir_keeps_the_pose_and_the_task_held(tmp_path: Path) -> None:
    args = agv_process.parse_args([*ARGS, "--state-dir", str(tmp_path)])
    driver = vehicle_driver(args, SPEC, HOME)
    assert isinstance(driver, SimDriver)
    StateFile(tmp_path / "agv-01.pose.json").write({"x": 3.5, "y": 37.5, "heading_rad": 0.0})
    again = vehicle_driver(args, SPEC, HOME)
    assert again is not None
    [first] = again.events()
    assert isinstance(first, PoseReported)
    assert (first.report.x, first.report.y) == (3.5, 37.5)
    task = TaskSpec("t-7", "S1", "S2")
    StateFile(tmp_path / "agv-01.task.json").write({"task": task.to_message(), "loaded": True})
    assert held_task(args) == (task, True)
    StateFile(tmp_path / "agv-01.task.json").write({"task": "t-7"})
    with pytest.raises(StateFileError, match="held task"):
        held_task(args)
    keeper = TaskKeeper(args)
    assert keeper is not None


def test_a_restarted_process_comes_back_where_the_vehicle_stands(tmp_path: Path) -> None:
    state = tmp_path / "state"
    state.mkdir()
    # It stood on its home's spur, facing the lane: it drives on to the lane, then home.
    pose_file = state / "agv-01.pose.json"
    StateFile(pose_file).write({"x": 3.5, "y": 37.5, "heading_rad": -math.pi / 2})
    command = [
        sys.executable,
        "-m",
        "agv_app.fleet.agv_process",
        "--id",
        "agv-01",
        "--insecure",
        "--secret-file",
        str(write_secret(tmp_path)),
        "--home",
        "P0350n",
        "--state-dir",
        str(state),
        "--t-update",
        "0.5",
        "--run-seconds",
        "14",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    events = [json.loads(line) for line in done.stdout.splitlines()]
    ready = next(e for e in events if e["event"] == "ready")
    assert ready["position"] == [3.5, 37.5]  # where it stood, not its home
    stands = json.loads(pose_file.read_text())
    assert (stands["x"], stands["y"]) == pytest.approx((3.5, 39.0))  # then it drove home
    assert json.loads((state / "agv-01.task.json").read_text()) is None
