"""``objectplaces agv`` and ``objectplaces control``: what they refuse, and why.

Bad input is refused with a line that names it and exit status 2: a home point not on
the layout, a layout that does not parse, credentials that cannot be used, and a
vehicle whose layout is not its fleet's (both digests named).
"""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from agv_app.layout.choice import layout_digest, layout_from_argument
from objectplaces.security import TemporaryPki

pytestmark = pytest.mark.processes

ROOT = Path(__file__).resolve().parents[3]
OPENTCS = ROOT / "agv_app" / "data" / "opentcs" / "Demo-01.xml"


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    with TemporaryPki(fleet="commands") as made:
        for agv in ("agv-01", "agv-02"):
            made.identity(agv, role="agv")
        yield made


def objectplaces(*argv: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "objectplaces.cli", *argv],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
    )


def test_a_home_point_not_on_the_layout_is_refused(pki: TemporaryPki) -> None:
    done = objectplaces("agv", "--id", "agv-01", "--pki", str(pki.directory), "--home", "P9")
    assert done.returncode == 2
    assert "--home 'P9' is no point of layout 'demo-warehouse'" in done.stderr


def test_a_layout_that_does_not_parse_is_refused(pki: TemporaryPki, tmp_path: Path) -> None:
    broken = tmp_path / "plant.json"
    broken.write_text("{not json")
    done = objectplaces(
        "agv", "--id", "agv-01", "--pki", str(pki.directory), "--layout", str(broken),
        "--home", "P0350n",
    )  # fmt: skip
    assert done.returncode == 2
    assert "--layout:" in done.stderr
    assert "plant.json" in done.stderr


def test_unusable_credentials_are_refused(tmp_path: Path) -> None:
    done = objectplaces("agv", "--id", "agv-01", "--pki", str(tmp_path), "--home", "P0350n")
    assert done.returncode == 2
    assert "ca.pem: cannot be read" in done.stderr


def test_a_vehicle_of_another_layout_is_refused_naming_both_digests(pki: TemporaryPki) -> None:
    ours = f"layout:{layout_digest(layout_from_argument(None))}"
    theirs = f"layout:{layout_digest(layout_from_argument(str(OPENTCS)))}"
    d = str(pki.directory)
    member = subprocess.Popen(
        [
            sys.executable, "-m", "objectplaces.cli", "agv", "--id", "agv-01", "--pki", d,
            "--listen", "127.0.0.1:0", "--home", "P0350n", "--expect-peers", "0",
            "--run-seconds", "60",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        stdin=subprocess.DEVNULL,
        text=True,
        cwd=ROOT,
    )  # fmt: skip
    try:
        assert member.stdout is not None
        ready = member.stdout.readline()
        address = ready.split('"address": "')[1].split('"')[0]
        done = objectplaces(
            "agv", "--id", "agv-02", "--pki", d, "--layout", str(OPENTCS), "--home",
            "Point-0002", "--connect", address,
        )  # fmt: skip
    finally:
        member.kill()
        member.wait(timeout=30)
        assert member.stdout is not None
        member.stdout.close()
    assert done.returncode == 2, done.stderr
    assert "refused by its fleet" in done.stderr
    assert ours in done.stderr
    assert theirs in done.stderr


def test_control_needs_the_certificates_of_its_nodes(pki: TemporaryPki) -> None:
    done = objectplaces("control", "--connect", "127.0.0.1:9")
    assert done.returncode == 2
    assert "give --pki DIR" in done.stderr
    done = objectplaces("control", "--connect", "127.0.0.1:9", "--pki", str(pki.directory))
    assert done.returncode == 2
    assert "observer.pem: cannot be read" in done.stderr


def test_an_unreachable_router_is_said_and_retried_with_backoff(pki: TemporaryPki) -> None:
    done = objectplaces(
        "agv",
        "--id",
        "agv-01",
        "--transport",
        "zenoh",
        "--mode",
        "client",
        "--connect",
        "tls/127.0.0.1:9",  # discard: nothing listens there
        "--pki",
        str(pki.directory),
        "--home",
        "P0350n",
        "--run-seconds",
        "4",
    )
    assert done.returncode == 0, done.stderr  # stopped by itself when its time was up
    events = [json.loads(line) for line in done.stdout.splitlines()]
    waits = [e["retry_in_s"] for e in events if e["event"] == "unreachable"]
    assert len(waits) >= 2
    assert waits == sorted(waits)  # backing off
    assert waits[-1] > waits[0]
    assert "cannot reach tls/127.0.0.1:9 yet" in done.stderr
