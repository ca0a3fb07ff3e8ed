"""What an AGV process keeps across a restart: its driver, and the task it holds.

``--driver`` picks the vehicle's driver: ``sim`` (the simulated kinematics, the
default) or ``standin`` (:mod:`agv_app.vehicle.standin`: noisy, late and lost pose
reports, a brake weaker than planned; for trying a fleet with vehicles that behave like
real ones). ``--state-dir DIR`` keeps, per AGV, two small JSON files there, each
replaced atomically (:mod:`agv_app.vehicle.state_file`):

* ``ID.pose.json``, the vehicle's pose, which the driver writes as the vehicle moves
  (a real vehicle knows where it stands; these two keep it for themselves);
* ``ID.task.json``, the task the AGV holds and whether its load is on board, which the
  process writes when either changes (:class:`TaskKeeper`).

A process started with a state directory comes back where the vehicle stands and hands
back the task it held (:mod:`agv_app.vehicle.comeback`); without one, the simulated
vehicle starts at its home, as it always did.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from agv_app.geometry import Pose
from agv_app.tasks.auction import TaskSpec
from agv_app.vehicle.comeback import held_from_json, held_to_json
from agv_app.vehicle.controller import AgvController
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.kinematics import VehicleSpec
from agv_app.vehicle.sim_driver import SimDriver
from agv_app.vehicle.standin import StandInDriver, standin_limits
from agv_app.vehicle.state_file import StateFile

__all__ = ["DRIVERS", "TaskKeeper", "add_driver_arguments", "held_task", "vehicle_driver"]

DRIVERS = ("sim", "standin")
"""The drivers an AGV process can run its vehicle with."""


def add_driver_arguments(parser: argparse.ArgumentParser) -> None:
    """``--driver`` and ``--state-dir``."""
    parser.add_argument(
        "--driver",
        choices=DRIVERS,
        default="sim",
        help="the vehicle's driver: the simulated kinematics, or a stand-in for a real "
        "vehicle (noisy, late and lost pose reports, a weaker brake)",
    )
    parser.add_argument(
        "--state-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="keep the vehicle's pose and the task held in DIR; a restarted process comes "
        "back where the vehicle stands",
    )


def _state(args: argparse.Namespace, kind: str) -> StateFile | None:
    directory: Path | None = args.state_dir
    if directory is None:
        return None
    directory.mkdir(parents=True, exist_ok=True)
    return StateFile(directory / f"{args.id}.{kind}.json")


def vehicle_driver(args: argparse.Namespace, spec: VehicleSpec, home: Pose) -> VehicleDriver | None:
    """The driver ``--driver`` and ``--state-dir`` ask for, the vehicle where it stands
    (at ``home`` with no state); None for the simulated one with no state (the
    controller builds that itself).

    Raises:
        StateFileError: the pose file holds no pose.
    """
    state = _state(args, "pose")
    if args.driver == "standin":
        limits = standin_limits(spec)
        if state is None:
            return StandInDriver(spec, home, limits=limits, seed=args.seed)
        return StandInDriver.recovered(spec, state, default=home, limits=limits, seed=args.seed)
    return None if state is None else SimDriver.recovered(spec, state, default=home)


def held_task(args: argparse.Namespace) -> tuple[TaskSpec, bool] | None:
    """The task the AGV held when its process stopped, and whether it was loaded.

    Raises:
        StateFileError: the task file holds something else.
    """
    state = _state(args, "task")
    return None if state is None else held_from_json(state.read())


class TaskKeeper:
    """Writes the task the AGV holds to ``ID.task.json`` whenever it changes.

    Args:
        args: the command line (``--state-dir``, ``--id``); no state dir: nothing.
    """

    def __init__(self, args: argparse.Namespace) -> None:
        self._state = _state(args, "task")
        self._kept: Any = ...

    def note(self, agv: AgvController) -> None:
        """Write the held task if it changed since the last write."""
        if self._state is None:
            return
        held = held_to_json(agv)
        if held != self._kept:
            self._state.write(held, durable=True)
            self._kept = held
