"""``objectplaces demo --vda5050 [URL]``: the fleet it builds and the broker it starts."""

from __future__ import annotations

import argparse
import socket

import pytest

import dashboard.cli
from agv_app.fleet import MeshFleet
from agv_app.fleet.demo import DEMO_AGVS
from agv_app.vda5050.broker import find_mosquitto
from agv_app.vda5050.sim_fleet import VdaSimFleet
from agv_app.vda5050.topics import parse_broker_url
from dashboard.cli import build_source, register, run_demo


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    return parser.parse_args(["demo", *argv])


def test_a_broker_url_builds_a_fleet_without_automatic_tasks() -> None:
    fleet = build_source(parse("--vda5050", "mqtt://127.0.0.1:1884"))
    assert isinstance(fleet, VdaSimFleet)
    assert fleet.vda5050 == "mqtt://127.0.0.1:1884"
    assert len(fleet.agvs) == DEMO_AGVS
    assert sorted(fleet.endpoints) == sorted(fleet.agvs)
    fleet.run(30.0)
    assert fleet.desk.book.counts["created"] == 0
    small = build_source(parse("--vda5050", "mqtt://127.0.0.1:1884", "--agvs", "3"))
    assert isinstance(small, VdaSimFleet)
    assert len(small.agvs) == 3
    processes = build_source(parse("--vda5050", "mqtt://127.0.0.1:1884", "--processes", "3"))
    assert isinstance(processes, MeshFleet)
    assert processes.vda5050 == "mqtt://127.0.0.1:1884"
    assert processes.agv_count == 3
    assert processes.task_interval is None
    assert parse().vda5050 is None


@pytest.mark.parametrize(
    "argv",
    [
        ("--vda5050", "http://127.0.0.1:1883"),
        ("--vda5050", "mqtt://:1883"),
        ("--vda5050", "mqtt://127.0.0.1:99999"),
    ],
)
def test_bad_vda5050_arguments_are_refused(
    argv: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    def builder(args: argparse.Namespace):
        raise AssertionError("must not build a fleet")

    assert run_demo(parse(*argv), builder=builder) == 2
    assert "--vda5050" in capsys.readouterr().err


def test_the_flag_alone_starts_a_local_broker_for_the_demo_and_stops_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    if find_mosquitto() is None:
        pytest.skip("mosquitto is not installed (make mosquitto)")
    seen: list[str] = []

    def serve(source: object, **kwargs: object) -> None:
        url = str(source)
        address = parse_broker_url(url)
        with socket.create_connection((address.host, address.port), timeout=5):
            seen.append(url)

    monkeypatch.setattr(dashboard.cli, "serve", serve)
    assert run_demo(parse("--vda5050"), builder=lambda args: args.vda5050) == 0
    (url,) = seen
    address = parse_broker_url(url)
    assert address.host == "127.0.0.1"
    with (
        pytest.raises(ConnectionRefusedError),
        socket.create_connection((address.host, address.port), 2),
    ):
        pass
