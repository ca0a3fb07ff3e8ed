"""Real node processes on Zenoh (127.0.0.1): peers that know only a chain of endpoints,
and clients of an ``objectplaces router`` process. A SIGKILLed node leaves its groups by
liveliness, long before the failure timeout (set to 60 s here) could notice it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.mesh.procs import ROOT, Cluster, NodeProcess
from tests.mesh.test_processes import check_only_members_speak, group_events

pytestmark = pytest.mark.processes

ZENOH = ["--transport", "zenoh", "--property-interval", "0.2", "--failure-timeout", "60"]


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    path = tmp_path / "secret"
    path.write_bytes(os.urandom(16).hex().encode())
    path.chmod(0o600)
    return path


@pytest.fixture
def cluster(secret_file: Path) -> Iterator[Cluster]:
    cluster = Cluster(secret_file, run_seconds=60.0)
    try:
        yield cluster
    finally:
        cluster.close()


@pytest.fixture
def router(secret_file: Path) -> Iterator[str]:
    """An ``objectplaces router`` process; yields its endpoint."""
    command = [
        sys.executable, "-m", "objectplaces.router_cli",
        "--listen", "tcp/127.0.0.1:0",
        "--insecure", "--secret-file", str(secret_file),
        "--run-seconds", "60",
    ]  # fmt: skip
    proc = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        assert proc.stdout is not None
        ready = json.loads(proc.stdout.readline())
        assert ready["event"] == "ready", ready
        yield str(ready["endpoints"][0])
    finally:
        proc.kill()
        proc.wait(timeout=10)
        if proc.stdout is not None:
            proc.stdout.close()


def run_session_and_kill(collector: NodeProcess, near: NodeProcess, doomed: NodeProcess) -> None:
    """Both echo nodes join the collector's group; SIGKILL one: it leaves the group."""
    for node in (near, doomed):
        node.send(cmd="move", x=1, y=0)
    collector.wait_event("in_group", peer=near.node_id)
    collector.wait_event("in_group", peer=doomed.node_id)
    collector.wait_for(lambda e: e.get("event") == "receive" and e["peer"] == doomed.node_id)
    doomed.kill()
    collector.wait_event("out_group", peer=doomed.node_id, timeout=15)
    mark = len(collector.events)
    collector.wait_for(
        lambda e: e.get("event") == "receive" and e["peer"] == near.node_id, since=mark
    )
    assert collector.quit() == 0
    assert near.quit() == 0
    assert group_events(collector)[-1] == ("out_group", doomed.node_id)
    assert set(check_only_members_speak(collector.events)) == {near.node_id, doomed.node_id}


def test_peers_on_a_chain_of_endpoints_and_a_killed_peer_leaves(cluster: Cluster) -> None:
    collector = cluster.start(
        "c", *ZENOH, "--role", "collector", "--group", "within:5", "--property", "position=[0,0]"
    )
    echo = ["--role", "echo", "--tick", "0.05", "--property", "position=[100,100]", *ZENOH]
    first = cluster.start("e1", *echo, "--connect", collector.address)
    second = cluster.start("e2", *echo, "--connect", first.address)  # knows only e1
    for node in (collector, first, second):
        node.wait_peers(2)
    run_session_and_kill(collector, first, second)


def test_clients_of_a_router_process_and_a_killed_client_leaves(
    cluster: Cluster, router: str
) -> None:
    client = [*ZENOH, "--mode", "client", "--connect", router]
    collector = cluster.start(
        "c", *client, "--role", "collector", "--group", "within:5", "--property", "position=[0,0]"
    )
    echo = ["--role", "echo", "--tick", "0.05", "--property", "position=[100,100]", *client]
    near, doomed = cluster.start("e1", *echo), cluster.start("e2", *echo)
    for node in (collector, near, doomed):
        node.wait_peers(2)
    run_session_and_kill(collector, near, doomed)
