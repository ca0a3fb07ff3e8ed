"""An AGV process's side of charging, without processes: the gate keeps an AGV due for a
charge out of service whatever the operator says, and an empty one held; the battery
spec reaches the process on its command line."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.agv_args import battery_spec
from agv_app.fleet.charge_listener import ServiceGate
from agv_app.fleet.mesh_options import AgvLaunch
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.battery import BatterySpec


def test_due_keeps_the_agv_out_of_service_and_empty_keeps_it_held() -> None:
    fleet = Fleet(demo_warehouse(), FleetConfig(agvs=1, seed=1, task_until=0.0))
    agv = fleet.agvs["agv-01"]
    gate = ServiceGate(agv)
    gate.set_due(True)
    assert not agv.in_service
    gate.return_to_service()  # the operator's word: due, it still takes no task
    assert not agv.in_service
    assert gate.in_service
    gate.set_due(False)
    assert agv.in_service
    gate.take_out_of_service()
    gate.set_due(False)
    assert not agv.in_service, "the operator's out of service stands"
    gate.return_to_service()
    gate.run_empty()
    assert agv.held
    assert not agv.in_service
    gate.release()
    gate.return_to_service()
    assert agv.held, "empty, it stays where it stands"
    assert not agv.in_service


def test_the_battery_spec_goes_to_the_process_as_json() -> None:
    spec = BatterySpec(charge_below=40.0, charge_to=70.0, initial=50.0)
    launch = AgvLaunch(
        "t", 1, 1.0, 60.0, 5.0, "websocket", "client", 0.2, 5, None, 0.05, None, spec
    )
    assert launch.battery_spec == spec
    argv = launch.arguments(0, "P1", [], Path("pki"), 1)
    text = argv[argv.index("--battery-spec") + 1]
    assert "--battery" in argv
    assert battery_spec(text) == spec
    assert json.loads(text)["charge_to"] == 70.0
    default = AgvLaunch(
        "t", 1, 1.0, 60.0, 5.0, "websocket", "client", 0.2, 5, None, 0.05, None, True
    )
    assert default.battery_spec == BatterySpec()
    for wrong in ("[1]", "{", '{"charge_below": 95}', '{"volts": 24}'):
        with pytest.raises(argparse.ArgumentTypeError):
            battery_spec(wrong)
