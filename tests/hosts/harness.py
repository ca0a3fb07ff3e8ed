"""A fleet across hosts: routers, a control process and vehicles, each in a namespace of
its own on one bridge, run by the project's own commands, and faults to put on them.

```python
with FleetOnHosts(vehicles=3, routers=2, workdir=tmp) as fleet:
    fleet.start()                      # routers, control, vehicles; waits until heard
    fleet.outage("agv-01", 2.0)        # its link down for two seconds
    fleet.kill("router", "r1")         # ... and the rest of the faults
    report = fleet.stop()              # every vehicle's own trace, merged: safe?
```

Every process runs ``python -m objectplaces.cli ...`` inside its host with certificates
of a throwaway fleet CA (routers named by their addresses), writes its output to a file
in ``workdir``, and stops by itself (``--run-seconds``); ``close`` kills whatever is
left and removes the namespaces. The test's own namespace has a leg on the bridge
(``10.X.0.1``), so the test reaches the control's REST API directly.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sqlite3
import ssl
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

from agv_app.fleet.parking import ParkingPlan
from agv_app.fleet.trace import SafetyReport, check_traces
from agv_app.layout.choice import layout_from_argument
from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M
from agv_app.tasks.desk import pick_stations
from agv_app.vehicle.kinematics import VehicleSpec
from objectplaces.security import TemporaryPki
from tests.netns import Host, Network

__all__ = ["FleetOnHosts", "Proc"]

ROOT = Path(__file__).resolve().parents[2]
ROUTER_PORT = 7447
DASHBOARD_PORT = 8443


@dataclass
class Proc:
    """One process of the fleet on its host."""

    kind: str
    name: str
    host: Host
    argv: list[str]
    log: Path
    popen: subprocess.Popen[bytes] | None = None
    starts: int = 0
    down: bool = False
    """Stopped on purpose (a fault): not running is no failure then."""

    def start(self, net: Network) -> None:
        """Start it (again) inside its host."""
        env = {**os.environ, "PYTHONUNBUFFERED": "1", "PYTHONPATH": str(ROOT)}
        with self.log.open("ab") as out:
            self.popen = subprocess.Popen(
                net.command(self.host, [sys.executable, "-m", "objectplaces.cli", *self.argv]),
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                env=env,
                cwd=ROOT,
                start_new_session=True,
            )
        self.starts += 1
        self.down = False

    def running(self) -> bool:
        """Whether it runs now."""
        return self.popen is not None and self.popen.poll() is None

    def signal(self, signum: int) -> None:
        """Send ``signum`` to its whole process group (``ip netns exec`` and the child)."""
        if self.popen is not None and self.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.popen.pid, signum)

    def reap(self, timeout: float = 20.0) -> int | None:
        """Wait for it to exit (SIGKILL after ``timeout``); its exit status."""
        if self.popen is None:
            return None
        try:
            return self.popen.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.signal(signal.SIGKILL)
            return self.popen.wait(timeout=10)


def _said(proc: Proc, text: str) -> bool:
    """Whether ``proc``'s log holds ``text``."""
    return proc.log.exists() and text in proc.log.read_text(errors="replace")


@dataclass
class FleetOnHosts:
    """Routers, a control process and vehicles on hosts of their own.

    Args:
        vehicles: how many vehicle processes.
        routers: how many Zenoh routers (linked to each other; every client lists all).
        workdir: where logs, traces, tokens and the order database go.
        layout: the ``--layout`` every process runs (None: the demo warehouse).
        load: the share of vehicles kept busy by the control's automatic tasks.
        run_seconds: every process stops by itself after this long.
    """

    vehicles: int
    workdir: Path
    routers: int = 2
    layout: str | None = None
    load: float = 0.7
    run_seconds: float = 600.0
    net: Network = field(init=False)
    pki: TemporaryPki = field(init=False)
    procs: dict[str, Proc] = field(init=False, default_factory=dict)
    events: list[tuple[float, str, str]] = field(init=False, default_factory=list)
    """``(wall time, what, who)`` of every fault: ``down``/``up``, ``kill``/``start``."""
    hosts: dict[str, Host] = field(init=False, default_factory=dict)

    def __post_init__(self) -> None:
        self.net = Network(bridged=True, attach=True)
        self.pki = TemporaryPki(fleet="hosts")
        self.traces = self.workdir / "traces"
        self.traces.mkdir(parents=True, exist_ok=True)
        layout = layout_from_argument(self.layout)
        self.picks = pick_stations(layout)
        spec = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M)
        self.homes = ParkingPlan(layout, spec, self.vehicles, rest_elsewhere=False).homes
        width = max(2, len(str(self.vehicles)))
        self.vehicle_ids = [f"agv-{i + 1:0{width}d}" for i in range(self.vehicles)]

    # -- building ---------------------------------------------------------------------

    def _host(self, name: str) -> Host:
        host = self.hosts[name] = self.net.host(name)
        return host

    def _layout_args(self) -> list[str]:
        return [] if self.layout is None else ["--layout", self.layout]

    def plan(self) -> None:
        """Make every host and certificate (all before any router starts: a router
        re-reads the roster whenever it changes)."""
        routers = [f"r{i + 1}" for i in range(self.routers)]
        for name in routers:
            host = self._host(name)
            self.pki.identity(name, role="router", addresses=(host.address,))
        ctl = self._host("ctl")
        for node in ("observer", "base"):
            self.pki.identity(node, role="control")
        self.pki.identity("control", role="control", addresses=(ctl.address,))
        for agv in self.vehicle_ids:
            self._host(agv.replace("agv-", "v"))
            self.pki.identity(agv, role="agv")
        endpoints = [f"tls/{self.hosts[r].address}:{ROUTER_PORT}" for r in routers]
        self.endpoints = endpoints
        connect = [a for e in endpoints for a in ("--connect", e)]
        d = str(self.pki.directory)
        seconds = str(self.run_seconds)
        for i, name in enumerate(routers):
            others = [a for e in endpoints[:i] for a in ("--connect", e)]
            self._proc("router", name, self.hosts[name], [
                "router", "--id", name, "--pki", d, "--listen", endpoints[i], *others,
                "--run-seconds", seconds,
            ])  # fmt: skip
        self.tokens = self.workdir / "tokens"
        self._proc("control", "control", ctl, [
            "control", "--transport", "zenoh", *connect, "--pki", d, *self._layout_args(),
            "--agvs", str(self.vehicles), "--load", str(self.load),
            "--host", ctl.address, "--port", str(DASHBOARD_PORT), "--token-file", str(self.tokens),
            "--db", str(self.workdir / "orders.sqlite"),
        ])  # fmt: skip
        for i, (agv, home) in enumerate(zip(self.vehicle_ids, self.homes, strict=True)):
            self._proc("agv", agv, self.hosts[agv.replace("agv-", "v")], [
                "agv", "--id", agv, "--transport", "zenoh", "--mode", "client", *connect,
                "--pki", d, *self._layout_args(), "--home", home, "--seed", str(i),
                "--trace", str(self.traces / f"{agv}.jsonl"), "--run-seconds", seconds,
            ])  # fmt: skip

    def _proc(self, kind: str, name: str, host: Host, argv: list[str]) -> None:
        self.procs[name] = Proc(kind, name, host, argv, self.workdir / f"{name}.log")

    # -- running ----------------------------------------------------------------------

    def start(self, *, within: float = 120.0) -> None:
        """Start routers, control and vehicles, and wait until the control hears every
        vehicle (bounded; a process that exits meanwhile fails it at once)."""
        self.plan()
        routers = [p for p in self.procs.values() if p.kind == "router"]
        for proc in routers:
            proc.start(self.net)
        self.until(lambda: all(_said(p, '"ready"') for p in routers), within, "routers ready")
        for kind in ("control", "agv"):
            for proc in self.procs.values():
                if proc.kind == kind:
                    proc.start(self.net)
        self.until(lambda: len(self.heard()) == self.vehicles, within, "every vehicle heard")

    def until(self, predicate: Callable[[], bool], within: float, what: str) -> float:
        """Wait until ``predicate()`` holds; the seconds it took. Fails naming ``what``,
        with the tail of every log, past ``within`` or when a process died."""
        start = time.monotonic()
        while not predicate():
            dead = [
                p.name for p in self.procs.values() if p.popen and not p.running() and not p.down
            ]
            if dead or time.monotonic() - start > within:
                raise AssertionError(
                    f"not {what} within {within} s (exited: {dead})\n{self.tails()}"
                )
            time.sleep(0.2)
        return time.monotonic() - start

    def tails(self, lines: int = 8) -> str:
        """The last lines of every process's log."""
        out = []
        for proc in self.procs.values():
            text = proc.log.read_text(errors="replace").splitlines() if proc.log.exists() else []
            out.append(f"--- {proc.name}:\n" + "\n".join(text[-lines:]))
        return "\n".join(out)

    # -- the control's view -------------------------------------------------------------

    def api(self, path: str, body: dict[str, Any] | None = None) -> Any:
        """GET ``path`` of the control's REST API, or POST ``body`` to it, as its
        operator; None while it is down."""
        token = next(
            line.split()[1]
            for line in self.tokens.read_text().splitlines()
            if line.startswith("operator ")
        )
        context = ssl.create_default_context(cafile=str(self.pki.directory / "ca.pem"))
        headers = {"Authorization": f"Bearer {token}"}
        data = None
        if body is not None:
            data = json.dumps(body).encode()
            headers["Content-Type"] = "application/json"
        request = urllib.request.Request(
            f"https://{self.hosts['ctl'].address}:{DASHBOARD_PORT}{path}",
            headers=headers,
            data=data,
        )
        try:
            with urllib.request.urlopen(request, timeout=5, context=context) as answer:
                return json.loads(answer.read())
        except OSError:
            return None

    def heard(self) -> list[str]:
        """Vehicles the control hears now (none while it is down)."""
        if not self.tokens.exists():
            return []
        vehicles = self.api("/api/vehicles") or []
        return sorted(v["id"] for v in vehicles if v.get("status") != "failed")

    def order(self, station: str) -> str:
        """Give the control a transport order at ``station``; its id."""
        answer = self.api("/api/tasks", {"station": station})
        assert answer is not None, "the control took no order"
        return str(answer["task_id"])

    def orders(self) -> dict[str, str]:
        """Every order the control knows and its state, by id ({} while it is down)."""
        return {t["id"]: t["state"] for t in self.api("/api/tasks") or []}

    def deliveries(self) -> dict[str, int]:
        """How often the order book recorded each order delivered (read after ``stop``)."""
        db = sqlite3.connect(f"file:{self.workdir / 'orders.sqlite'}?mode=ro", uri=True)
        try:
            rows = db.execute("SELECT id, history FROM tasks").fetchall()
        finally:
            db.close()
        return {
            task: sum(1 for entry in json.loads(history) if entry[0] == "done")
            for task, history in rows
        }

    def metrics(self) -> dict[str, float]:
        """The control's figures ({} while it is down)."""
        answer = self.api("/api/metrics") or {}
        return {k: v for k, v in answer.get("metrics", {}).items() if v is not None}

    # -- faults ---------------------------------------------------------------------------

    def outage(self, name: str, seconds: float) -> None:
        """Take the host of ``name`` off the network for ``seconds``, then back."""
        host = self.procs[name].host
        self.net.link_down(host)
        self.events.append((time.time(), "down", name))
        time.sleep(seconds)
        self.net.link_up(host)
        self.events.append((time.time(), "up", name))

    def kill(self, name: str) -> None:
        """Kill ``name`` with SIGKILL (a crash, a power cut)."""
        proc = self.procs[name]
        proc.down = True
        proc.signal(signal.SIGKILL)
        proc.reap(10)
        self.events.append((time.time(), "kill", name))

    def restart(self, name: str) -> None:
        """Start ``name`` again on its host."""
        self.procs[name].start(self.net)
        self.events.append((time.time(), "start", name))

    # -- ending ---------------------------------------------------------------------------

    def stop(self) -> SafetyReport:
        """Stop every process (SIGTERM, then SIGKILL), merge the vehicles' traces."""
        for kind in ("agv", "control", "router"):
            for proc in self.procs.values():
                if proc.kind == kind:
                    proc.down = True
                    proc.signal(signal.SIGTERM)
            for proc in self.procs.values():
                if proc.kind == kind:
                    proc.reap(20)
        return check_traces(self.traces.glob("*.jsonl"))

    def close(self) -> None:
        """Kill whatever runs, remove the namespaces and the throwaway CA."""
        for proc in self.procs.values():
            proc.signal(signal.SIGKILL)
            if proc.popen is not None:
                proc.reap(10)
        self.net.close()
        self.pki.remove()

    def __enter__(self) -> FleetOnHosts:
        return self

    def __exit__(
        self,
        _type: type[BaseException] | None,
        _value: BaseException | None,
        _tb: TracebackType | None,
    ) -> None:
        self.close()
