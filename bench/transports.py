"""The WebSocket mesh against Zenoh (peers, and clients of a router): one workload, one run.

Run: ``.venv/bin/python bench/transports.py`` (``--sizes 10,20`` or ``--transports
zenoh-peer`` for less, ``zenoh-client-polled5`` for clients polling every 5 ms;
``--fleet-agvs 0`` skips the fleet run; ``--fleet-only`` runs the
fleet alone and rewrites only its part; ``--fleet-against before`` runs it first as
before the real-time work, ``--fleet-against no-rest`` without nodes at rest).

For each transport and size, every node a separate process on 127.0.0.1:

- fan-out: one node publishes a position every 2 ms; the time from
  ``update_node_property`` to the property observer on every other node (one monotonic
  clock for every process on this machine), and the CPU each other node spends
  meanwhile (its process time over the phase's wall time, Zenoh's threads included);
- throughput: every node publishes as fast as it can for a few seconds; position
  updates received per second per node;
- session setup: ``start_interaction`` until ``in_group`` from every other node;
- bytes per update: the property frame's payload, plus the transport's framing of it
  (a WebSocket frame header; for Zenoh, the bytes one session writes to another per
  update, counted by a TCP relay between two nodes in this process).

The floors, measured in the same run: a plain ``websockets`` echo round trip and a plain
Zenoh put/subscribe round trip of the same payload between two processes. Last, a fleet
of AGV processes on Zenoh (``MeshFleet``: clients of a router in this process, as
``objectplaces demo --processes N --transport zenoh`` runs it) runs for a while; its
safety counters are read. ``--before-size`` adds Zenoh peers receiving as before the
receive-path work, in the same run, to show what that work bought.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Literal

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE.parent]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import zenoh  # noqa: E402

from bench import report as bench_report  # noqa: E402
from bench.mesh import Counter, Silent, measure_floor, percentile, position_frame, say  # noqa: E402
from bench.mesh import Proc as _MeshProc  # noqa: E402
from bench.mesh import Worker as MeshWorker  # noqa: E402
from bench.report import machine_summary, markdown_table, publish  # noqa: E402
from bench.transports_wire import zenoh_bytes_per_update  # noqa: E402
from objectplaces import groups  # noqa: E402
from objectplaces.activator import RoleActivator  # noqa: E402
from objectplaces.mesh import MeshOptions, start_mesh_node  # noqa: E402
from objectplaces.transport import zenoh_inbox  # noqa: E402
from objectplaces.transport.zenoh_config import derive_credentials  # noqa: E402
from objectplaces.transport.zenoh_inbox import direct  # noqa: E402
from objectplaces.transport.zenoh_keys import FleetKeys  # noqa: E402
from objectplaces.zenoh_node import start_zenoh_node  # noqa: E402

SECRET = b"the bench fleet secret, 32 bytes or more"
TRANSPORTS = ["mesh", "zenoh-peer", "zenoh-client", "zenoh-peer-polled", "zenoh-client-polled"]
POLL_INTERVAL = 0.05
"""``-polled``: Zenoh nodes with polled reception (``poll_interval``, the AGV processes'
setting): received frames handed on together every this many seconds."""
BEFORE = "zenoh-peer-before"
"""Zenoh peers receiving as before the receive-path work (``receive_path_as_before``),
measured in the same run at ``--before-size`` nodes: what that work bought."""
FANOUT_COUNT = 300
FANOUT_GAP = 0.002
BLAST_SECONDS = 3.0
SESSIONS = 20
PEERS_TIMEOUT = 110.0
"""Seconds a worker waits to see every other node (the coordinator waits 120 s)."""


# ---------------------------------------------------------------------------- worker side


class Worker(MeshWorker):
    """The mesh bench's worker, also measuring CPU and counting every drop."""

    async def blast(self, start: float, seconds: float) -> dict[str, Any]:
        self.window = (start, start + seconds)
        self.in_window = 0
        await asyncio.sleep(max(0.0, start - time.monotonic()))
        cpu = time.process_time()
        sent = 0
        y = 1000.0 + self.index
        while time.monotonic() < start + seconds:
            sent += 1
            self.node.update_node_property("position", (float(sent % 50_000) + 1.0, y))
            await asyncio.sleep(0)
        cpu = time.process_time() - cpu
        await asyncio.sleep(0.5)
        drops = sum(v for k, v in self.node.transport_counters().items() if "dropped" in k)
        drops += sum(s.drops for s in self.node.peer_stats().values())
        return {"sent": sent, "received": self.in_window, "drops": drops, "cpu": cpu}

    async def sessions(self, count: int, expected: int) -> list[float]:
        times = []
        for _ in range(count):
            counter = Counter(expected)
            start = time.monotonic()
            session = self.node.start_interaction(counter, groups.within(10_000.0), "silent")
            async with asyncio.timeout(20):
                await counter.done.wait()
            times.append(time.monotonic() - start)
            self.node.stop_interaction(session)
            for _ in range(10_000):
                if not self.node.machine.state_counts()["sessions"]:
                    break
                await asyncio.sleep(0.001)
        return times


def receive_path_as_before() -> None:
    """This process's Zenoh nodes receive as before the receive-path work: each data
    sample's callback on Zenoh's own thread, and each sample's key parsed afresh."""
    zenoh_inbox.batched = zenoh_inbox.direct
    FleetKeys.parse = FleetKeys._parse  # type: ignore[method-assign]


async def start_worker_node(node_id: str, transport: str, connect: list[str]) -> RoleActivator:
    timing: dict[str, Any] = {
        "insecure": True,  # plain links on 127.0.0.1
        "secret": SECRET,
        "property_interval": 1.0,
        "failure_timeout": 60.0,
    }
    base, poll, before = split_transport(transport)
    if before:  # BEFORE, or zenoh-client-before by hand
        receive_path_as_before()
    if base == "mesh":
        options = MeshOptions(queue_size=65_536, flood_rate=1e7, flood_burst=1e6)
        return await start_mesh_node(node_id, join=connect, options=options, **timing)
    mode: Literal["client", "peer"] = "client" if base == "zenoh-client" else "peer"
    return await start_zenoh_node(node_id, connect=connect, mode=mode, poll_interval=poll, **timing)


def split_transport(transport: str) -> tuple[str, float | None, bool]:
    """``zenoh-peer-polled`` -> (``zenoh-peer``, ``POLL_INTERVAL``, not before);
    ``zenoh-client-polled5`` polls every 5 ms; None: by callback."""
    before = transport.endswith("-before")
    transport = transport.removesuffix("-before")
    base, polled, ms = re.fullmatch(r"(.*?)(-polled(\d*))?", transport).groups()  # type: ignore[union-attr]
    poll = None if polled is None else int(ms) / 1000 if ms else POLL_INTERVAL
    return base, poll, before


async def run_worker(node_id: str, index: int, transport: str, connect: list[str]) -> None:
    node: Any = await start_worker_node(node_id, transport, connect)
    node.set_participant_factory("silent", Silent)
    node.update_node_property("position", (float(index), -1.0))
    worker = Worker(node, index)
    say(ready=node.address)
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader()
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    cpu_mark = (time.monotonic(), time.process_time())
    async with asyncio.timeout(900):
        while line := await reader.readline():
            cmd = json.loads(line)
            match cmd["cmd"]:
                case "peers":
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(PEERS_TIMEOUT):
                            await node.wait_for_peers(cmd["n"])
                    say(peers=len(node.peers()))
                case "cpu_mark":
                    cpu_mark = (time.monotonic(), time.process_time())
                    say(ok=True)
                case "cpu":
                    wall = time.monotonic() - cpu_mark[0]
                    seconds = time.process_time() - cpu_mark[1]
                    say(cpu=seconds / max(wall, 1e-9), seconds=seconds)
                case "fanout":
                    say(sent=await worker.fanout(cmd["count"], cmd["gap"]))
                case "receipts":
                    say(receipts=worker.receipts)
                    worker.receipts = {}
                case "blast":
                    say(**await worker.blast(cmd["start"], cmd["seconds"]))
                case "sessions":
                    say(times=await worker.sessions(cmd["count"], cmd["expected"]))
                case "stats":
                    frames, size = node.machine.sent_by_kind.get("property", [0, 0])
                    say(property_frames=frames, property_bytes=size)
                case "quit":
                    break
    await node.close()


async def run_zenoh_echo(key: str) -> None:
    """A bare Zenoh session that puts back on ``key/pong`` what it hears on ``key/ping``."""
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    config.insert_json5("scouting/multicast/enabled", "false")
    port = _free_port()
    config.insert_json5("listen/endpoints", f'["tcp/127.0.0.1:{port}"]')
    session = zenoh.open(config)

    def pong(sample: zenoh.Sample) -> None:
        session.put(f"{key}/pong", sample.payload.to_bytes())

    session.declare_subscriber(f"{key}/ping", direct(pong))
    say(ready=f"tcp/127.0.0.1:{port}")
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    session.close()  # type: ignore[no-untyped-call]


async def run_zenoh_listener(endpoint: str, mode: str) -> None:
    """A bare Zenoh session (no node) that notes when each numbered sample of
    ``FLOOR_KEY`` arrives, in the callback on Zenoh's thread; tells them at ``quit``."""
    config = bare_config("client" if mode == "client" else "peer", [endpoint])
    if mode != "client":
        config.insert_json5("scouting/gossip/enabled", "false")  # the publisher's link only
    session = zenoh.open(config)
    heard: dict[int, float] = {}
    cpu_at_first: list[float] = []

    def note(sample: zenoh.Sample) -> None:
        if not heard:
            cpu_at_first.append(time.process_time())
        heard[int.from_bytes(sample.payload.to_bytes()[:4], "little")] = time.monotonic()

    session.declare_subscriber(FLOOR_KEY, direct(note))
    say(ready=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.readline)
    # From the first sample to 0.5 s after the last, as a node's CPU in the fan-out phase.
    cpu = time.process_time() - (cpu_at_first[0] if cpu_at_first else time.process_time())
    say(heard=heard, cpu=cpu)
    session.close()  # type: ignore[no-untyped-call]


FLOOR_KEY = "objectplaces/default/bench/fan"


def bare_config(mode: str, connect: list[str], listen: list[str] | None = None) -> zenoh.Config:
    """A bare Zenoh session's configuration (no authentication), on 127.0.0.1 only;
    with the fleet's credentials when ``connect`` is our router (it accepts no other)."""
    config = zenoh.Config()
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("listen/endpoints", json.dumps(listen or []))
    config.insert_json5("connect/endpoints", json.dumps(connect))
    config.insert_json5("scouting/multicast/enabled", "false")
    if mode == "client":
        credentials = derive_credentials(SECRET, "default")
        auth = {"user": credentials.user, "password": credentials.password}
        config.insert_json5("transport/auth/usrpwd", json.dumps(auth))
    return config


async def zenoh_fanout_floor(listeners: int, mode: str) -> dict[str, float]:
    """The fan-out phase's workload with bare Zenoh sessions: one publisher puts
    ``FANOUT_COUNT`` 8-byte samples ``FANOUT_GAP`` apart to ``listeners`` bare
    subscriber processes (peers linked to the publisher, or clients of our router
    process); the p50 and p99 from put to each subscriber's callback, and the share
    delivered. What no node code costs: the floor of this machine for that fan-out."""
    router: Proc | None = None
    procs: list[Proc] = []
    session: zenoh.Session | None = None
    try:
        if mode == "client":
            router, endpoint = await start_router_proc()
            config = bare_config("client", [endpoint])
        else:
            endpoint = f"tcp/127.0.0.1:{_free_port()}"
            config = bare_config("peer", [], [endpoint])
            config.insert_json5("scouting/gossip/enabled", "false")
        session = await asyncio.to_thread(zenoh.open, config)
        for _ in range(listeners):
            procs.append(await Proc.start_script(HERE, "--zenoh-listen", endpoint, "--mode", mode))
        for proc in procs:
            await proc.recv()
        await asyncio.sleep(2.0)  # every subscription known to the publisher (or router)
        sent = []
        for i in range(FANOUT_COUNT):
            sent.append(time.monotonic())
            session.put(FLOOR_KEY, i.to_bytes(4, "little") + bytes(4))
            await asyncio.sleep(FANOUT_GAP)
        await asyncio.sleep(0.5)
        latencies, cpu = [], []
        for proc in procs:
            reply = await proc.ask(cmd="quit")
            latencies += [t - sent[int(i)] for i, t in reply["heard"].items()]
            cpu.append(reply["cpu"])
        return {
            "p50": percentile(latencies, 50),
            "p99": percentile(latencies, 99),
            "delivered": len(latencies) / (FANOUT_COUNT * listeners),
            "cpu_per_update": statistics.mean(cpu) / FANOUT_COUNT,
        }
    finally:
        if session is not None:
            await asyncio.to_thread(session.close)
        await asyncio.gather(*(p.stop() for p in procs))
        if router is not None:
            await router.stop()


def _free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


# ---------------------------------------------------------------------------- coordinator


class Proc(_MeshProc):
    """A worker process: this script, another script, or a module."""

    @classmethod
    async def start_script(cls, script: Path, *args: str) -> Proc:
        return await cls._exec(str(script), *args)

    @classmethod
    async def start_module(cls, module: str, *args: str) -> Proc:
        return await cls._exec("-m", module, *args)

    @classmethod
    async def _exec(cls, *args: str) -> Proc:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, *args,
            cwd=ROOT, stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
            limit=1 << 24,
        )  # fmt: skip
        return cls(proc)


async def zenoh_floor(payload: bytes) -> float:
    """Plain Zenoh round trip p50 (put, the echo's put back) between two processes."""
    echo = await Proc.start_script(HERE, "--zenoh-echo", "bench/echo")
    try:
        endpoint = (await echo.recv())["ready"]
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("listen/endpoints", "[]")
        config.insert_json5("connect/endpoints", f'["{endpoint}"]')
        config.insert_json5("scouting/multicast/enabled", "false")
        session = await asyncio.to_thread(zenoh.open, config)
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[float] = asyncio.Queue()

        def heard(_sample: zenoh.Sample) -> None:
            loop.call_soon_threadsafe(queue.put_nowait, time.monotonic())

        session.declare_subscriber("bench/echo/pong", direct(heard))
        await asyncio.sleep(0.5)
        rtts = []
        for i in range(2200):
            start = time.monotonic()
            session.put("bench/echo/ping", payload)
            async with asyncio.timeout(5):
                end = await queue.get()
            if i >= 200:
                rtts.append(end - start)
        await asyncio.to_thread(session.close)
        return percentile(rtts, 50)
    finally:
        await echo.stop()


async def start_router_proc() -> tuple[Proc, str]:
    secret_file = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench-secret-{os.getpid()}"
    secret_file.write_bytes(SECRET)
    secret_file.chmod(0o600)
    proc = await Proc.start_module(
        "objectplaces.router_cli", "--listen", "tcp/127.0.0.1:0",
        "--insecure", "--secret-file", str(secret_file), "--run-seconds", "900",
    )  # fmt: skip
    ready = await proc.recv()
    secret_file.unlink()
    return proc, str(ready["endpoints"][0])


async def measure(transport: str, size: int) -> dict[str, Any]:
    procs: list[Proc] = []
    router: Proc | None = None
    try:
        connect: list[str] = []
        started = time.monotonic()
        client = split_transport(transport)[0] == "zenoh-client"
        if client:
            router, endpoint = await start_router_proc()
            connect = [endpoint]
        seed = await Proc.start_script(HERE, "--worker", "w0", "--index", "0",
                                       "--transport", transport,
                                       *[a for c in connect for a in ("--connect", c)])  # fmt: skip
        procs.append(seed)
        address = (await seed.recv())["ready"]
        if not client:
            connect = [address]
        for i in range(1, size):
            args = ["--worker", f"w{i}", "--index", str(i), "--transport", transport]
            procs.append(
                await Proc.start_script(
                    HERE, *args, *[a for c in connect for a in ("--connect", c)]
                )
            )
        for proc in procs[1:]:
            await proc.recv()
        seen = [
            r["peers"]
            for r in await asyncio.gather(*(p.ask(cmd="peers", n=size - 1) for p in procs))
        ]
        if min(seen) < size - 1:
            raise RuntimeError(
                f"not formed within {PEERS_TIMEOUT:g} s: each node saw {min(seen)} to "
                f"{max(seen)} others (median {statistics.median(seen):g}) of {size - 1}"
            )
        formed = time.monotonic() - started
        await asyncio.sleep(1.0)

        await asyncio.gather(*(p.ask(cmd="cpu_mark") for p in procs[1:]))
        seed.send(cmd="fanout", count=FANOUT_COUNT, gap=FANOUT_GAP)
        sent = (await seed.recv())["sent"]
        await asyncio.sleep(0.5)
        cpu_replies = [await p.ask(cmd="cpu") for p in procs[1:]]
        cpu = [r["cpu"] for r in cpu_replies]
        latencies = []
        for proc in procs[1:]:
            receipts = (await proc.ask(cmd="receipts"))["receipts"]
            latencies += [t - sent[int(i)] for i, t in receipts.items()]
        delivered = len(latencies) / (FANOUT_COUNT * (size - 1))
        wire = await seed.ask(cmd="stats")
        times = (await seed.ask(cmd="sessions", count=SESSIONS, expected=size - 1))["times"]
        start = time.monotonic() + 0.5
        results = await asyncio.gather(
            *(p.ask(cmd="blast", start=start, seconds=BLAST_SECONDS) for p in procs)
        )
        received = [r["received"] / BLAST_SECONDS for r in results]
        return {
            "transport": transport,
            "size": size,
            "fan_p50": percentile(latencies, 50),
            "fan_p99": percentile(latencies, 99),
            "delivered": delivered,
            "cpu_fanout": statistics.mean(cpu),
            "cpu_per_update": statistics.mean(r["seconds"] for r in cpu_replies) / FANOUT_COUNT,
            "cpu_blast": statistics.mean(r["cpu"] for r in results) / BLAST_SECONDS,
            "setup_p50": percentile(times, 50),
            "recv": statistics.mean(received),
            "recv_min": min(received),
            "drops": sum(r["drops"] for r in results),
            "payload": wire["property_bytes"] / max(1, wire["property_frames"]),
            "formed": formed,
        }
    finally:
        await asyncio.gather(*(p.stop() for p in procs))
        if router is not None:
            await router.stop()


def _step_lag(logs: dict[str, str]) -> tuple[int, int, float]:
    """Control steps, steps late by over a step, and the longest lag of every AGV
    process, from the last ``lag`` or ``closed`` line each has written so far."""
    steps = late = 0
    longest = 0.0
    for log in logs.values():
        last = None
        for line in log.splitlines():
            if line.startswith('{"event": "lag"') or line.startswith('{"event": "closed"'):
                last = json.loads(line)
        if last is not None and "steps" in last:
            steps += last["steps"]
            late += last["late_steps"]
            longest = max(longest, last["max_lag_s"])
    return steps, late, longest


def _cpu_seconds(pid: int) -> float:
    """User and system CPU time of a process so far (Linux /proc)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


FLEET_BEFORE = {"poll_interval": 0.0, "republish_beats": 0, "publish_interval": 0.2}
"""The AGV processes' reception and publication settings before the real-time work
(issue 12): each frame handed on at once, every property republished each second, a
pose every 0.2 s. What is code, not settings, is in both runs: a subscriber per row of
cells instead of per cell, the display's introspection at most once a second."""

FLEET_BASELINES: dict[str, tuple[str, dict[str, Any]]] = {
    "before": ("as before", FLEET_BEFORE),
    "no-rest": ("without rest", {"rest_beat": None}),
}
"""``--fleet-against``: the fleet run first in the same slot, as a baseline; by name,
its column's label and the ``MeshFleet`` settings it changes. ``no-rest``: parked AGVs
beat every second like the others (docs/protocol.md §2, "A node at rest")."""


async def run_fleet(agvs: int, seconds: float, settings: dict[str, Any]) -> dict[str, Any]:
    """A fleet of AGV processes on Zenoh, as ``objectplaces demo --processes N
    --transport zenoh`` runs it (with ``settings`` of ``MeshFleet`` changed), for
    ``seconds`` after every AGV is heard."""
    from agv_app.fleet.demo import demo_source
    from agv_app.fleet.mesh import MeshFleet

    fleet = demo_source(processes=agvs, seed=1, transport="zenoh")
    assert isinstance(fleet, MeshFleet)
    for name, value in settings.items():
        setattr(fleet, name, value)
    await fleet.start()
    try:
        ready_at = time.monotonic()
        async with asyncio.timeout(180):
            await fleet.wait_ready()
        ready = time.monotonic() - ready_at
        cpu0 = sum(_cpu_seconds(pid) for pid in fleet.pids())
        own0 = time.process_time()
        lag0 = _step_lag(fleet.child_logs())
        start = time.monotonic()
        frame = 0.1
        late = 0
        next_at = start
        while (now := time.monotonic()) < start + seconds:
            if now - next_at > 0.5:
                late += 1  # the driver itself fell half a second behind
            fleet.advance(frame)
            next_at += frame
            await asyncio.sleep(max(0.0, next_at - time.monotonic()))
        wall = time.monotonic() - start
        cpu = sum(_cpu_seconds(pid) for pid in fleet.pids()) - cpu0
        own = time.process_time() - own0
        lag1 = _step_lag(fleet.child_logs())
        fleet.check()
        metrics = fleet.metrics()
    finally:
        await fleet.stop()
    # The run's steps: from the AGVs' last reports before it to their last within it.
    steps, late_steps = lag1[0] - lag0[0], lag1[1] - lag0[1]
    life = _step_lag(fleet.final_logs)
    return {
        "agvs": agvs, "seconds": wall, "ready": ready, "metrics": metrics,
        "cpu_cores": cpu / wall, "own_cores": own / wall, "late": late,
        "steps": steps, "late_steps": late_steps, "life": life,
        "publish_interval": fleet.publish_interval,
    }  # fmt: skip


def fleet_table(runs: dict[str, dict[str, Any]]) -> str:
    """The fleet runs side by side, one column each."""

    def row(label: str, cell: Any) -> list[Any]:
        return [label, *(cell(f) for f in runs.values())]

    def share(late: int, steps: int) -> str:
        return f"{late:,} / {steps:,} ({late / max(steps, 1):.2%})"

    return markdown_table(
        ["fleet on Zenoh", *runs],
        [
            row("AGV processes", lambda f: f"{f['agvs']}, clients of a router in this process"),
            row("pose published every", lambda f: f"{f['publish_interval']:g} s"),
            row("run (after every AGV was heard)", lambda f: f"{f['seconds']:.0f} s"),
            row("time until every AGV was heard", lambda f: f"{f['ready']:.1f} s"),
            row("CPU of the AGV processes", lambda f: f"{f['cpu_cores']:.2f} cores"),
            row("CPU of this process (router, observer, stations)",
                lambda f: f"{f['own_cores']:.2f} cores"),
            row("AGVs failed", lambda f: int(f["metrics"]["agvs_failed"])),
            row("tasks created / completed",
                lambda f: f"{f['metrics']['tasks_created']:.0f} / "
                f"{f['metrics']['tasks_completed']:.0f}"),
            row("collisions / lock overlaps / deadlocks",
                lambda f: f"{f['metrics']['collisions']:.0f} / "
                f"{f['metrics']['lock_overlaps']:.0f} / {f['metrics']['deadlocks']:.0f}"),
            row("stalls over 60 s", lambda f: f"{f['metrics']['stalls_60s']:.0f}"),
            row("frames of this driver late by over 0.5 s", lambda f: f["late"]),
            row("AGV control steps (0.1 s) late by over a step / all, in the run",
                lambda f: share(f["late_steps"], f["steps"])),
            row("the same over the processes' whole life (start-up included)",
                lambda f: f"{share(f['life'][1], f['life'][0])}, longest lag "
                f"{f['life'][2]:.2f} s"),
        ],
    )  # fmt: skip


def fleet_verdict(fleet: dict[str, Any]) -> str:
    """Issue 12's verdict on one fleet run."""
    m = fleet["metrics"]
    violations = int(m["collisions"] + m["lock_overlaps"] + m["deadlocks"])
    late_share = fleet["late_steps"] / max(fleet["steps"], 1)
    realtime = late_share < 0.01 and m["agvs_failed"] == 0
    return f"- {fleet['agvs']} AGV processes on Zenoh at real time with 0 violations: " + verdict(
        violations == 0 and realtime,
        f"{violations} violations, {late_share:.2%} of the control steps late by "
        f"over a step, {fleet['cpu_cores']:.2f} cores busy",
        f"{violations} violations, {late_share:.2%} of the control steps late by over a "
        f"step (goal < 1%), {int(m['agvs_failed'])} AGVs failed",
    )


async def measure_fleets(agvs: int, seconds: float, against: str | None) -> tuple[str, list[str]]:
    """The fleet phase: the fleet as it runs now (first the baseline ``against`` names,
    if any, in the same slot); its markdown and what did not complete."""
    runs: dict[str, dict[str, Any]] = {}
    failed: list[str] = []
    first = [FLEET_BASELINES[against]] if against else []
    for label, settings in [*first, ("now", {})]:
        print(f"running {agvs} AGV processes on Zenoh ({label}) ...", file=sys.stderr)
        try:
            runs[label] = await run_fleet(agvs, seconds, settings)
            print(json.dumps(runs[label], default=repr), file=sys.stderr)
        except TimeoutError:
            failed.append(
                f"the fleet of {agvs} AGV processes ({label}): not every AGV heard in 180 s"
            )
    lines = (
        [fleet_verdict(runs["now"])]
        if "now" in runs
        else [
            f"- {agvs} AGV processes on Zenoh at real time with 0 violations: missed "
            "(the fleet did not form: not every AGV heard within 180 s)"
        ]
    )
    baseline = FLEET_BASELINES[against][0] if against else None
    if "now" in runs and baseline in runs:
        now, was = runs["now"], runs[baseline]
        ratio = (was["late_steps"] / max(was["steps"], 1)) / max(
            now["late_steps"] / max(now["steps"], 1), 1e-9
        )
        lines.append(
            f"- now against {baseline}, same run: the AGV processes' CPU "
            f"{was['cpu_cores']:.2f} -> {now['cpu_cores']:.2f} cores "
            f"({was['cpu_cores'] / max(now['cpu_cores'], 1e-9):.2f}x less), this process "
            f"{was['own_cores']:.2f} -> {now['own_cores']:.2f} cores, late control "
            f"steps {was['late_steps'] / max(was['steps'], 1):.2%} -> "
            f"{now['late_steps'] / max(now['steps'], 1):.2%}"
            + (f" ({ratio:.1f}x fewer)" if now["late_steps"] else "")
        )
    parts = [fleet_table(runs) if runs else "", "\n".join(f"- {f}" for f in failed)]
    parts.append("Goal (issue 12):\n" + "\n".join(lines))
    return "\n\n".join(p for p in parts if p), failed


FLOOR_SIZE = 50
"""The fan-out goal's size; the bare Zenoh floor is measured at it."""
FLOOR_LINKS = {"peer": "peers linked to the publisher", "client": "clients of a router process"}


def reception(transport: str) -> str:
    """How a row's Zenoh nodes hand received frames on, in words."""
    poll = split_transport(transport)[1]
    if poll is not None:
        return f"polled every {poll * 1000:g} ms"
    return "each frame as it arrives"


def standing_fleet_block() -> str:
    """The fleet's part as BENCHMARKS.md has it now (kept by a run without the fleet)."""
    path = bench_report.BENCHMARKS_PATH
    text = path.read_text() if path.exists() else ""
    start, end = f"<!-- bench:{FLEET_SECTION} -->", f"<!-- /bench:{FLEET_SECTION} -->"
    if start not in text or end not in text:
        return ""
    return text[text.index(start) : text.index(end) + len(end)]


def verdict(ok: bool, met: str, missed: str) -> str:
    return f"met ({met})" if ok else f"missed ({missed})"


FLEET_SECTION = "transports-fleet"
FLEET_TITLE = "Transports: AGV processes on Zenoh in real time (bench/transports.py)"


def fleet_block(body: str, command: str) -> str:
    """The fleet's part of the transports section, in markers of its own, so that
    ``--fleet-only`` rewrites it alone (the same layout as ``bench.report.publish``)."""
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    return (
        f"<!-- bench:{FLEET_SECTION} -->\n## {FLEET_TITLE}\n\n"
        f"Measured {stamp} on {machine_summary()}, {_commit()}.  \n"
        f"Reproduce: `{command}`\n\n{body.strip()}\n<!-- /bench:{FLEET_SECTION} -->"
    )


def _commit() -> str:
    """The commit measured, and whether the tree differed from it."""
    try:
        head = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no", "--", *_CODE],
            cwd=ROOT, capture_output=True, text=True,
        ).stdout.strip()  # fmt: skip
    except OSError:
        return "commit unknown"
    return f"commit {head}" + (" (with uncommitted changes to the code)" if dirty else "")


_CODE = ("objectplaces", "agv_app", "tuplespace", "bench")
"""The code a fleet run executes: changes elsewhere (docs) do not make it another run."""


async def fleet_only(agvs: int, seconds: float, against: str | None) -> None:
    """Run only the fleet phase and rewrite only its part of BENCHMARKS.md."""
    body, _ = await measure_fleets(agvs, seconds, against)
    load = os.getloadavg()[0]
    body = (
        f"At {_commit()}. Only this phase ran (`--fleet-only`); the rows above are from "
        f"the run they name. {os.cpu_count()} CPUs shared with whatever else ran (load "
        f"average {load:.0f} at the end). {FLEET_NOTE}\n\n{body}"
    )
    command = ".venv/bin/python bench/transports.py --fleet-only" + (
        f" --fleet-against {against}" if against else ""
    )
    publish(FLEET_SECTION, FLEET_TITLE, body, command)


FLEET_NOTE = (
    "The demo fleet (`objectplaces demo --processes N --transport zenoh`): a router, the "
    "observer and the stations in the bench's process, every AGV a process of its own, a "
    "client of the router; tasks at the demo's load. Late steps are read from what each "
    "AGV process reports every 5 s, over the measured run. A baseline column, when there "
    "is one, is the same fleet run first in the same slot: `as before` with the "
    "reception and publication settings before the real-time work (each frame handed on "
    "at once, every property republished each second, a pose every 0.2 s), `without "
    "rest` with parked AGVs beating every second like the others; what is code, not "
    "settings, is in both."
)


async def coordinate(
    sizes: list[int],
    transports: list[str],
    fleet_agvs: int,
    fleet_s: float,
    before_size: int,
    fleet_against: str | None,
) -> None:
    payload = position_frame()
    load_before = os.getloadavg()[0]
    echo = await Proc.start_script(ROOT / "bench" / "mesh.py", "--echo-server")
    try:
        ws_floor = await measure_floor((await echo.recv())["ready"], payload)
    finally:
        await echo.stop()
    z_floor = await zenoh_floor(payload)
    z_wire = await zenoh_bytes_per_update(SECRET)
    fan_floors = {}
    if FLOOR_SIZE in sizes:
        for mode in ("peer", "client"):
            print(f"measuring the bare Zenoh fan-out floor ({mode}) ...", file=sys.stderr)
            fan_floors[mode] = await zenoh_fanout_floor(FLOOR_SIZE - 1, mode)
            print(json.dumps(fan_floors[mode]), file=sys.stderr)
    rows = []
    failed: list[str] = []
    for size in sizes:
        for transport in [*transports, *([BEFORE] if size == before_size else [])]:
            print(f"measuring {transport} with {size} nodes ...", file=sys.stderr)
            try:
                rows.append(await measure(transport, size))
                print(json.dumps(rows[-1]), file=sys.stderr)
            except (TimeoutError, RuntimeError) as exc:
                # A network that did not form in time is a result too: say so, go on.
                print(f"{transport} with {size} nodes failed: {exc!r}", file=sys.stderr)
                failed.append(f"{transport} at {size} nodes: {type(exc).__name__} {exc}")
    fleet_text = standing_fleet_block()
    if fleet_agvs:
        fleet_body, fleet_failed = await measure_fleets(fleet_agvs, fleet_s, fleet_against)
        failed += fleet_failed
        fleet_text = fleet_block(
            f"{FLEET_NOTE}\n\n{fleet_body}",
            ".venv/bin/python bench/transports.py --fleet-only"
            + (f" --fleet-against {fleet_against}" if fleet_against else ""),
        )

    ms = 1000.0
    ws_wire = len(payload) + 2  # a WebSocket frame from the listening side: 2-byte header
    table = markdown_table(
        [
            "transport", "nodes", "fan-out p50 ms", "fan-out p99 ms", "delivered",
            "updates recv/s per node (min)", "CPU per node, fan-out", "CPU per node, blast",
            "setup p50 ms", "drops", "bytes per update", "formed in s",
        ],
        [
            [
                r["transport"], r["size"], f"{r['fan_p50'] * ms:.3f}", f"{r['fan_p99'] * ms:.3f}",
                f"{r['delivered']:.1%}", f"{r['recv']:,.0f} ({r['recv_min']:,.0f})",
                f"{r['cpu_fanout']:.0%}", f"{r['cpu_blast']:.0%}", f"{r['setup_p50'] * ms:.2f}",
                r["drops"],
                f"{ws_wire if r['transport'] == 'mesh' else z_wire:.0f} "
                f"({r['payload']:.0f} payload)", f"{r['formed']:.1f}",
            ]
            for r in rows
        ],
    )  # fmt: skip
    floors = markdown_table(
        ["floor, same payload, two processes", "value"],
        [
            ["plain websockets echo round trip p50", f"{ws_floor['rtt_p50'] * ms:.3f} ms"],
            ["plain Zenoh put/subscribe round trip p50", f"{z_floor * ms:.3f} ms"],
            *[
                [
                    f"plain Zenoh fan-out to {FLOOR_SIZE - 1} bare subscriber processes "
                    f"({FLOOR_LINKS[mode]}), "
                    "p50 / p99 (delivered), CPU per update per subscriber",
                    f"{f['p50'] * ms:.3f} / {f['p99'] * ms:.3f} ms ({f['delivered']:.1%}), "
                    f"{f['cpu_per_update'] * 1e6:.0f} µs",
                ]
                for mode, f in fan_floors.items()
            ],
        ],
    )
    by = {(r["transport"], r["size"]): r for r in rows}
    verdicts = []
    mesh20 = by.get(("mesh", 20))
    for transport in [t for t in transports if t != "mesh"]:
        zen20 = by.get((transport, 20))
        if mesh20 and zen20:
            ratio = zen20["recv"] / max(mesh20["recv"], 1e-9)
            verdicts.append(
                f"- {transport} ({reception(transport)}) >= 5x the mesh's received updates "
                "per node at 20 nodes: "
                + verdict(ratio >= 5, f"{ratio:.1f}x", f"{ratio:.1f}x")
                + f" (CPU per node in the blast: mesh {mesh20['cpu_blast']:.0%}, "
                f"{transport} {zen20['cpu_blast']:.0%}; {(os.cpu_count() or 1) / 20:.0%} per "
                "node is every core full)"
            )
    now, before = by.get(("zenoh-peer", before_size)), by.get((BEFORE, before_size))
    if now and before:
        verdicts.append(
            f"- what the receive-path work bought, {before_size} Zenoh peers, same run: "
            f"{now['recv'] / max(before['recv'], 1e-9):.2f}x the updates received per node, "
            f"fan-out p50 {now['fan_p50'] * ms:.2f} ms against {before['fan_p50'] * ms:.2f} ms"
        )
    floor = min(ws_floor["rtt_p50"], z_floor)
    for transport in transports:
        r = by.get((transport, FLOOR_SIZE))
        if r and transport != "mesh":
            ratio = r["fan_p50"] / floor
            bare = fan_floors.get(split_transport(transport)[0].removeprefix("zenoh-"))
            verdicts.append(
                f"- {transport} ({reception(transport)}): fan-out p50 at {FLOOR_SIZE} nodes "
                f"<= 3x the plain round trip ({floor * ms:.3f} ms): "
                + verdict(ratio <= 3, f"{ratio:.1f}x", f"{ratio:.1f}x")
                + (
                    f"; bare Zenoh sessions, same links, no node: {bare['p50'] * ms:.2f} ms "
                    f"({bare['p50'] / floor:.1f}x); CPU per update per receiver: node "
                    f"{r['cpu_per_update'] * 1e6:.0f} µs, bare subscriber "
                    f"{bare['cpu_per_update'] * 1e6:.0f} µs"
                    if bare
                    else ""
                )
            )
    for transport in transports:
        r = by.get((transport, FLOOR_SIZE))
        if transport.startswith("zenoh-peer") and (r or any(transport in f for f in failed)):
            verdicts.append(
                f"- {transport}: {FLOOR_SIZE} peers form: "
                + (
                    verdict(True, f"every peer saw every other {r['formed']:.1f} s after the "
                            "first started, processes started one after another", "")
                    if r
                    else verdict(False, "", "did not form, above")
                )
            )  # fmt: skip
    body = "\n\n".join(
        part
        for part in [
            f"Loopback, one process per node, {os.cpu_count()} CPUs shared by every process "
            "(and by whatever else runs on the machine: load average "
            f"{load_before:.0f} at the start, {os.getloadavg()[0]:.0f} at the end). "
            "Same workload as bench/mesh.py: "
            f"fan-out = one node publishes {FANOUT_COUNT} positions {FANOUT_GAP * ms:g} ms "
            "apart, latency to the observer callback on each other node, CPU = process time "
            f"per wall second of each receiving node; throughput = every node publishes as fast "
            f"as it can for {BLAST_SECONDS:g} s; setup = {SESSIONS} sessions in a row, "
            "`start_interaction` until `in_group` from every other node. Zenoh peers connect "
            "to the first node and find the others by gossip; Zenoh clients connect to an "
            "`objectplaces router` process; `-polled` = Zenoh nodes with polled reception "
            f"(`poll_interval` {POLL_INTERVAL * ms:g} ms, the AGV processes' setting: received "
            "frames handed on together once per interval), the others hand each frame on "
            "as it arrives; `zenoh-peer-before` = Zenoh peers receiving as "
            "before the receive-path work (each sample's callback on Zenoh's own thread, "
            "each key parsed afresh). Bytes per update: WebSocket frame (payload + "
            "2-byte header) or the bytes a Zenoh session writes per update, counted by a relay. "
            "Formed in: from the first process's start (one after another) until every node "
            "saw every other. Bare fan-out floor: the fan-out phase's puts from a bare Zenoh "
            "session to bare subscriber processes (a callback on Zenoh's thread notes the "
            "time), the same links as the nodes', no node code.",
            table,
            floors,
            "Runs that did not complete (the network did not form, or a phase timed out):\n"
            + "\n".join(f"- {f}" for f in failed)
            if failed
            else "",
            "Goals (issue 12):\n" + "\n".join(verdicts),
            fleet_text,
        ]
        if part
    )
    publish(
        "transports",
        "Transports: the WebSocket mesh against Zenoh (bench/transports.py)",
        body,
        ".venv/bin/python bench/transports.py",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="10,20,50")
    parser.add_argument("--transports", default=",".join(TRANSPORTS))
    parser.add_argument("--fleet-agvs", type=int, default=50)
    parser.add_argument("--fleet-seconds", type=float, default=60.0)
    parser.add_argument(
        "--fleet-only", action="store_true", help="run the fleet phase alone (its part only)"
    )
    parser.add_argument(
        "--fleet-against",
        choices=sorted(FLEET_BASELINES),
        help="run the fleet first as this baseline, same run: 'before' the real-time "
        "work, or with 'no-rest'",
    )
    parser.add_argument("--before-size", type=int, default=20, help="0: no before row")
    parser.add_argument("--worker")
    parser.add_argument("--index", type=int, default=0)
    parser.add_argument("--transport", default="mesh")
    parser.add_argument("--connect", action="append", default=[])
    parser.add_argument("--zenoh-echo")
    parser.add_argument("--zenoh-listen")
    parser.add_argument("--mode", default="peer")
    args = parser.parse_args()
    if args.worker:
        asyncio.run(run_worker(args.worker, args.index, args.transport, args.connect))
    elif args.zenoh_echo:
        asyncio.run(run_zenoh_echo(args.zenoh_echo))
    elif args.zenoh_listen:
        asyncio.run(run_zenoh_listener(args.zenoh_listen, args.mode))
    elif args.fleet_only:
        asyncio.run(fleet_only(args.fleet_agvs, args.fleet_seconds, args.fleet_against))
    else:
        asyncio.run(
            coordinate(
                [int(s) for s in args.sizes.split(",")],
                args.transports.split(","),
                args.fleet_agvs,
                args.fleet_seconds,
                args.before_size,
                args.fleet_against,
            )
        )


if __name__ == "__main__":
    main()
