"""``objectplaces router`` and ``objectplaces node --transport zenoh`` as processes: a
credential that cannot be used is named, with exit status 2; SIGTERM and SIGINT close
cleanly and leave no credentials file behind; nodes of a TLS router hold a session."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from objectplaces.security import TemporaryPki
from tests.mesh.procs import ROOT, Cluster
from tests.zenoh.test_processes import run_session_and_kill

pytestmark = pytest.mark.processes

SECRET = b"a fleet secret of 32 bytes or more"


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    path = tmp_path / "secret"
    path.write_bytes(SECRET)
    path.chmod(0o600)
    return path


def start(module: str, *args: str, tmp: Path) -> subprocess.Popen[bytes]:
    """``python -m module args`` with its temporary files in ``tmp``."""
    env = {**os.environ, "TMPDIR": str(tmp)}
    return subprocess.Popen(
        [sys.executable, "-m", module, *args],
        cwd=ROOT,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )


def events(out: bytes) -> list[dict[str, Any]]:
    return [json.loads(line) for line in out.splitlines() if line.startswith(b"{")]


@pytest.mark.parametrize(
    ("args", "says"),
    [
        ([], "give --pki DIR"),
        (["--pki", "/no/such/folder"], "PKI folder /no/such/folder: not a folder"),
        (["--insecure"], "--insecure needs --secret-file"),
        (["--insecure", "--secret-file", "/no/such/file"], "secret file /no/such/file"),
    ],
)
def test_a_credential_that_cannot_be_used_is_named_with_status_2(
    args: list[str], says: str, tmp_path: Path
) -> None:
    env = {k: v for k, v in os.environ.items() if k != "OBJECTPLACES_SECRET"}
    for module, name in (("objectplaces.router_cli", "router"), ("objectplaces.node_cli", "node")):
        extra = ["--id", "a", "--transport", "zenoh"] if name == "node" else []
        done = subprocess.run(
            [sys.executable, "-m", module, *extra, *args],
            cwd=ROOT,
            env=env,
            capture_output=True,
            timeout=60,
            check=False,
        )
        assert done.returncode == 2, done
        assert done.stderr.decode().startswith(f"objectplaces {name}: "), done.stderr
        assert says in done.stderr.decode()


def test_a_secret_file_others_can_read_is_refused(secret_file: Path) -> None:
    secret_file.chmod(0o644)
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "objectplaces.router_cli",
            "--insecure",
            "--secret-file",
            str(secret_file),
        ],
        cwd=ROOT,
        capture_output=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "lets group or others read it" in done.stderr.decode()


def credential_dirs(tmp: Path) -> list[Path]:
    return sorted(tmp.glob("objectplaces-zenoh-*"))


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_closes_the_router_and_removes_its_credentials(
    signum: signal.Signals, secret_file: Path, tmp_path: Path
) -> None:
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    args = ["--listen", "tcp/127.0.0.1:0", "--insecure", "--secret-file", str(secret_file)]
    proc = start("objectplaces.router_cli", *args, tmp=tmp)
    assert proc.stdout is not None
    ready = json.loads(proc.stdout.readline())
    assert ready["event"] == "ready"
    assert len(credential_dirs(tmp)) == 1
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert events(out)[-1]["event"] == "closed"
    assert events(out)[-1]["reason"] == signum.name
    assert credential_dirs(tmp) == []


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_makes_a_zenoh_node_leave_and_remove_its_credentials(
    signum: signal.Signals, secret_file: Path, tmp_path: Path
) -> None:
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    args = ["--id", "a", "--transport", "zenoh", "--insecure", "--secret-file", str(secret_file)]
    proc = start("objectplaces.node_cli", *args, tmp=tmp)
    assert proc.stdout is not None
    ready = json.loads(proc.stdout.readline())
    assert ready["event"] == "ready", ready
    assert len(credential_dirs(tmp)) == 1
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert events(out)[-1]["event"] == "closed"
    assert credential_dirs(tmp) == []


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    with TemporaryPki(fleet="f") as pki:
        pki.identity("r1", role="router", addresses=("127.0.0.1",))
        for node in ("c", "e1", "e2"):
            pki.identity(node, role="agv")
        yield pki


@pytest.fixture
def tls_router(pki: TemporaryPki, tmp_path: Path) -> Iterator[str]:
    """An ``objectplaces router`` process with its certificate; yields its endpoint."""
    args = ["--id", "r1", "--pki", str(pki.directory), "--listen", "tls/127.0.0.1:0"]
    proc = start("objectplaces.router_cli", *args, "--run-seconds", "90", tmp=tmp_path)
    try:
        assert proc.stdout is not None
        ready = json.loads(proc.stdout.readline())
        assert ready["event"] == "ready", ready
        yield str(ready["endpoints"][0])
    finally:
        proc.kill()
        proc.communicate(timeout=10)


def test_clients_of_a_tls_router_process_and_a_killed_client_leaves(
    pki: TemporaryPki, tls_router: str
) -> None:
    cluster = Cluster(pki=pki.directory, run_seconds=60.0)
    client = [
        "--transport", "zenoh", "--mode", "client", "--connect", tls_router,
        "--property-interval", "0.2", "--failure-timeout", "60",
    ]  # fmt: skip
    try:
        collector = cluster.start(
            "c", *client, "--role", "collector", "--group", "within:5", "--property",
            "position=[0,0]",
        )  # fmt: skip
        echo = ["--role", "echo", "--tick", "0.05", "--property", "position=[100,100]", *client]
        near, doomed = cluster.start("e1", *echo), cluster.start("e2", *echo)
        for node in (collector, near, doomed):
            node.wait_peers(2)
        run_session_and_kill(collector, near, doomed)
    finally:
        cluster.close()
