"""``objectplaces demo --vda5050 [URL]``: the fleet it builds, the broker it starts, what it
refuses, and that its broker and throwaway PKI are gone after a clean exit, SIGINT or
SIGTERM."""

from __future__ import annotations

import argparse
import asyncio
import os
import re
import signal
import socket
import sys
from pathlib import Path

import pytest

import dashboard.cli
from agv_app.fleet import MeshFleet
from agv_app.fleet.demo import DEMO_AGVS
from agv_app.vda5050.broker import find_mosquitto
from agv_app.vda5050.demo import MASTER_ID
from agv_app.vda5050.link import VdaCredentials, mqtt_link, probe_broker
from agv_app.vda5050.sim_fleet import VdaSimFleet
from agv_app.vda5050.topics import parse_broker_url
from dashboard.cli import build_source, register, run_demo
from dashboard.listen import CONTROL_ID
from objectplaces.security import Identity, TemporaryPki
from tests.waiting import until

needs_mosquitto = pytest.mark.skipif(
    find_mosquitto() is None, reason="mosquitto is not installed (make mosquitto)"
)


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    return parser.parse_args(["demo", *argv])


def closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_a_broker_url_builds_a_fleet_without_automatic_tasks(pki: TemporaryPki) -> None:
    url = "mqtts://127.0.0.1:8884"
    args = parse("--vda5050", url, "--pki", str(pki.directory))
    args.vda5050_credentials = VdaCredentials(pki)
    fleet = build_source(args)
    assert isinstance(fleet, VdaSimFleet)
    assert fleet.vda5050 == url
    assert len(fleet.agvs) == DEMO_AGVS
    assert sorted(fleet.endpoints) == sorted(fleet.agvs)
    for agv_id, link in fleet.links.items():
        assert link.client_id == agv_id
        assert link.identity is not None
        assert link.identity.role == "agv"
    fleet.run(30.0)
    assert fleet.desk.book.counts["created"] == 0
    small = parse("--vda5050", url, "--agvs", "3")
    small.vda5050_credentials = VdaCredentials(pki)
    built = build_source(small)
    assert isinstance(built, VdaSimFleet)
    assert len(built.agvs) == 3
    processes = parse("--vda5050", url, "--processes", "3")
    processes.vda5050_credentials = VdaCredentials(pki)
    mesh = build_source(processes)
    assert isinstance(mesh, MeshFleet)
    assert mesh.vda5050 == url
    assert mesh.agv_count == 3
    assert mesh.task_interval is None
    assert parse().vda5050 is None


def test_a_plain_broker_is_had_on_loopback_when_asked_for_by_name() -> None:
    args = parse("--vda5050", "mqtt://127.0.0.1:1884", "--insecure")
    args.vda5050_credentials = VdaCredentials(insecure=True)
    fleet = build_source(args)
    assert isinstance(fleet, VdaSimFleet)
    assert all(link.identity is None for link in fleet.links.values())


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (("--vda5050", "http://127.0.0.1:1883"), "mqtts://HOST:PORT"),
        (("--vda5050", "mqtts://:1883"), "no host"),
        (("--vda5050", "mqtt://127.0.0.1:99999", "--insecure"), "port"),
        (("--vda5050", "mqtts://127.0.0.1:8883"), "--pki DIR"),
        (("--vda5050", "mqtt://127.0.0.1:1883"), "--pki DIR"),
        (("--vda5050", "mqtt://10.1.2.3:1883", "--insecure"), "loopback only"),
        (("--vda5050", "mqtts://127.0.0.1:8883", "--insecure"), "not --insecure"),
        (("--vda5050", "mqtts://127.0.0.1:8883", "--pki", "/nonexistent/pki"), "not a folder"),
        (("--vda5050", "--pki", "/nonexistent/pki"), "not a folder"),
    ],
)
def test_bad_vda5050_arguments_are_refused(
    argv: tuple[str, ...], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    def builder(args: argparse.Namespace):
        raise AssertionError("must not build a fleet")

    assert run_demo(parse(*argv), builder=builder) == 2
    err = capsys.readouterr().err
    assert err.startswith("objectplaces demo: ")
    assert said in err
    assert "Traceback" not in err


def test_an_unreachable_broker_is_refused_by_name(
    pki: TemporaryPki, capsys: pytest.CaptureFixture[str]
) -> None:
    url = f"mqtts://127.0.0.1:{closed_port()}"
    pki.identity(CONTROL_ID, role="control")  # --pki: the dashboard serves TLS with it

    def builder(args: argparse.Namespace):
        raise AssertionError("must not build a fleet")

    assert run_demo(parse("--vda5050", url, "--pki", str(pki.directory)), builder=builder) == 2
    err = capsys.readouterr().err
    assert f"broker {url} is unreachable" in err


def test_a_fleet_certificate_missing_is_refused_by_name(
    pki: TemporaryPki, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    args = parse("--vda5050", "mqtts://127.0.0.1:8884", "--pki", str(pki.directory))
    args.vda5050_credentials = VdaCredentials(pki.directory)  # agv-03 was never issued
    with pytest.raises(SystemExit) as stopped:
        build_source(args)
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert "agv-03.pem" in err
    assert "Traceback" not in err


@needs_mosquitto
def test_the_flag_alone_starts_a_broker_with_a_throwaway_pki_and_removes_both(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen: list[tuple[str, Path]] = []

    def serve(source: object, **kwargs: object) -> None:
        url = str(source)
        assert url.startswith("mqtts://127.0.0.1:")
        out = capsys.readouterr().out
        found = re.search(r"connects with the certificate (\S+) ", out)
        assert found, out
        cert = Path(found.group(1))
        master = Identity.from_pki(cert.parent, MASTER_ID)
        assert master.role == "master"
        probe_broker(mqtt_link(url, tls=master))  # TLS, and the broker takes the master
        seen.append((url, cert.parent))

    monkeypatch.setattr(dashboard.cli, "serve", serve)
    assert run_demo(parse("--vda5050"), builder=lambda args: args.vda5050) == 0
    ((url, folder),) = seen
    address = parse_broker_url(url)
    with (
        pytest.raises(ConnectionRefusedError),
        socket.create_connection((address.host, address.port), 2),
    ):
        pass
    assert not folder.exists()


@needs_mosquitto
@pytest.mark.processes
@pytest.mark.parametrize(
    ("signum", "when"),
    [(signal.SIGTERM, "serving"), (signal.SIGINT, "serving"), (signal.SIGTERM, "starting")],
)
async def test_a_signal_stops_the_demo_s_broker_and_removes_its_files(
    signum: signal.Signals, when: str, tmp_path: Path
) -> None:
    temp = tmp_path / "tmp"
    temp.mkdir()
    port = closed_port()
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "objectplaces.cli",
        "demo",
        "--vda5050",
        "--agvs",
        "2",
        "--port",
        str(port),
        stdin=asyncio.subprocess.DEVNULL,
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
        env={**os.environ, "TMPDIR": str(temp)},
    )
    assert proc.stdout is not None
    assert proc.stderr is not None
    try:
        lines: list[str] = []
        last = "VDA 5050 over" if when == "starting" else "dashboard at"
        async with asyncio.timeout(120):
            while not any(line.startswith(last) for line in lines):
                line = (await proc.stdout.readline()).decode()
                assert line, f"the demo ended: {lines} {(await proc.stderr.read()).decode()}"
                lines.append(line)
        (said,) = [line for line in lines if line.startswith("VDA 5050 over")]
        address = parse_broker_url(said.split()[3].rstrip(";"))
        assert any(p.name.startswith("objectplaces-pki-") for p in temp.iterdir())
        assert any(p.name.startswith("objectplaces-mqtt-") for p in temp.iterdir())

        def serving() -> bool:  # uvicorn has its signal handlers once it listens
            try:
                socket.create_connection(("127.0.0.1", port), 1).close()
            except OSError:
                return False
            return True

        if when == "serving":
            await until(serving, within=60)
        proc.send_signal(signum)
        async with asyncio.timeout(60):
            status = await proc.wait()
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
    err = (await proc.stderr.read()).decode()
    # SIGINT ends uvicorn's serving; whether asyncio then raises KeyboardInterrupt (130)
    # depends on when the signal lands: either way the demo unwinds.
    assert status in ((143,) if signum == signal.SIGTERM else (0, 130)), err
    assert "Traceback" not in err

    def refused() -> bool:
        try:
            socket.create_connection((address.host, address.port), 1).close()
        except ConnectionRefusedError:
            return True
        return False

    await until(refused, within=10)
    assert list(temp.iterdir()) == []
