"""The WebSocket mesh on loopback: 2, 10 and 20 node processes against plain websockets.

Run: ``.venv/bin/python bench/mesh.py`` (``--sizes 2,10`` for fewer).

Measured for each mesh size, each node a separate process:

- fan-out latency: one node publishes a position every 2 ms; the time from
  ``update_node_property`` to the property observer on every other node (both read
  ``time.monotonic()``, one clock for every process on this machine);
- property updates received per second per node while every node publishes as fast as
  it can for a few seconds (all-to-all, the worst case of full dissemination);
- session setup: ``start_interaction`` until the initiator has seen ``in_group`` from
  every other node;
- wire bytes of one position update, the WebSocket frame header included.

The floor, measured in the same run: a plain ``websockets`` echo of the same payload
between two processes (round trip), and one process sending it to another as fast as
it can (messages per second).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent
# Run as a script, bench/ itself comes first on the path and its tuplespace.py would
# shadow the package of that name.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE.parent]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from websockets.asyncio.client import connect  # noqa: E402
from websockets.asyncio.server import ServerConnection, serve  # noqa: E402
from websockets.frames import Frame, Opcode  # noqa: E402

from bench.report import markdown_table, publish  # noqa: E402
from objectplaces import Initiator, Participant, groups  # noqa: E402
from objectplaces.core import codec  # noqa: E402
from objectplaces.core.messages import PropertyUpdate  # noqa: E402
from objectplaces.mesh import MeshOptions, start_node  # noqa: E402
from objectplaces.network_node import NetworkNode  # noqa: E402
from objectplaces.roles import ParticipantRef  # noqa: E402

SECRET = b"bench-secret-of-plain-loopback-links"
FANOUT_COUNT = 300
FANOUT_GAP = 0.002
BLAST_SECONDS = 3.0
SESSIONS = 40


# ---------------------------------------------------------------------------- worker side


def say(**fields: Any) -> None:
    sys.stdout.write(json.dumps(fields) + "\n")
    sys.stdout.flush()


class Silent(Participant):
    """A participant that only accepts."""


class Counter(Initiator):
    """Sets ``done`` when ``expected`` members are in the group."""

    def __init__(self, expected: int) -> None:
        self.expected = expected
        self.seen = 0
        self.done = asyncio.Event()

    def in_group(self, p: ParticipantRef) -> None:
        self.seen += 1
        if self.seen == self.expected:
            self.done.set()


class Worker:
    def __init__(self, node: NetworkNode, index: int) -> None:
        self.node = node
        self.index = index
        self.receipts: dict[int, float] = {}
        self.window: tuple[float, float] = (0.0, 0.0)
        self.in_window = 0
        node.register_node_property_observer(self.observe)

    def observe(self, node_id: str, name: str, value: Any) -> None:
        if node_id == self.node.node_id or name != "position":
            return
        now = time.monotonic()
        if node_id == "w0" and value[0] == 0.0 and value[1] >= 0.0:
            self.receipts[round(value[1] * 10)] = now
        if self.window[0] <= now <= self.window[1]:
            self.in_window += 1

    async def fanout(self, count: int, gap: float) -> list[float]:
        sent = []
        for i in range(count):
            sent.append(time.monotonic())
            self.node.update_node_property("position", (0.0, i / 10))
            await asyncio.sleep(gap)
        return sent

    async def blast(self, start: float, seconds: float) -> dict[str, Any]:
        self.window = (start, start + seconds)
        self.in_window = 0
        await asyncio.sleep(max(0.0, start - time.monotonic()))
        sent = 0
        y = 1000.0 + self.index
        while time.monotonic() < start + seconds:
            sent += 1
            self.node.update_node_property("position", (float(sent % 50_000) + 1.0, y))
            await asyncio.sleep(0)
        await asyncio.sleep(0.5)
        drops = sum(s.drops for s in self.node.peer_stats().values())
        return {"sent": sent, "received": self.in_window, "drops": drops}

    async def sessions(self, count: int, expected: int) -> list[float]:
        times = []
        for _ in range(count):
            counter = Counter(expected)
            start = time.monotonic()
            session = self.node.start_interaction(counter, groups.within(10_000.0), "silent")
            async with asyncio.timeout(10):
                await counter.done.wait()
            times.append(time.monotonic() - start)
            self.node.stop_interaction(session)
            for _ in range(10_000):  # until the stopped session is forgotten (acks in)
                if not self.node.machine.state_counts()["sessions"]:
                    break
                await asyncio.sleep(0.001)
        return times


async def run_worker(node_id: str, index: int, join: list[str]) -> None:
    node = await start_node(
        node_id,
        join=join,
        insecure=True,  # the mesh's own cost; bench/tls.py measures what TLS adds
        secret=SECRET,
        property_interval=1.0,
        failure_timeout=60.0,
        options=MeshOptions(queue_size=65_536, flood_rate=1e7, flood_burst=1e6),
    )
    node.set_participant_factory("silent", Silent)
    node.update_node_property("position", (float(index), -1.0))
    worker = Worker(node, index)
    say(ready=node.address)
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader()
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    async with asyncio.timeout(600):
        while line := await reader.readline():
            cmd = json.loads(line)
            match cmd["cmd"]:
                case "peers":
                    async with asyncio.timeout(60):
                        await node.wait_for_peers(cmd["n"])
                    say(peers=len(node.peers()))
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


# ---------------------------------------------------------------------------- floor


async def run_echo_server() -> None:
    async def handler(ws: ServerConnection) -> None:
        path = ws.request.path if ws.request is not None else "/"
        if path == "/sink":
            count = 0
            async for message in ws:
                if message == b"done":
                    await ws.send(str(count))
                    continue
                count += 1
        else:
            async for message in ws:
                await ws.send(message)

    async with serve(handler, "127.0.0.1", 0, compression=None) as server:
        say(ready=f"127.0.0.1:{server.sockets[0].getsockname()[1]}")
        reader = asyncio.StreamReader()
        await asyncio.get_running_loop().connect_read_pipe(
            lambda: asyncio.StreamReaderProtocol(reader), sys.stdin
        )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(600):
                await reader.read()  # until the coordinator closes our stdin


async def measure_floor(address: str, payload: bytes) -> dict[str, float]:
    rtts = []
    async with connect(f"ws://{address}/echo", compression=None, proxy=None) as ws:
        for _ in range(200):
            await ws.send(payload)
            await ws.recv()
        for _ in range(3000):
            start = time.monotonic()
            await ws.send(payload)
            await ws.recv()
            rtts.append(time.monotonic() - start)
    count = 100_000
    async with connect(f"ws://{address}/sink", compression=None, proxy=None) as ws:
        start = time.monotonic()
        for _ in range(count):
            await ws.send(payload)
        await ws.send(b"done")
        received = int(await ws.recv())
        elapsed = time.monotonic() - start
    return {
        "rtt_p50": percentile(rtts, 50),
        "rtt_p99": percentile(rtts, 99),
        "rate": received / elapsed,
    }


# ---------------------------------------------------------------------------- coordinator


def percentile(values: list[float], p: float) -> float:
    ordered = sorted(values)
    if not ordered:
        return float("nan")
    k = min(len(ordered) - 1, max(0, round(p / 100 * (len(ordered) - 1))))
    return ordered[k]


class Proc:
    def __init__(self, proc: asyncio.subprocess.Process) -> None:
        self.proc = proc

    @classmethod
    async def start(cls, *args: str) -> Proc:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, str(HERE), *args,
            stdin=asyncio.subprocess.PIPE, stdout=asyncio.subprocess.PIPE,
            limit=1 << 24,
        )  # fmt: skip
        return cls(proc)

    def send(self, **cmd: Any) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(cmd).encode() + b"\n")

    async def recv(self) -> dict[str, Any]:
        assert self.proc.stdout is not None
        async with asyncio.timeout(120):
            while True:
                line = await self.proc.stdout.readline()
                if not line:
                    raise RuntimeError("worker exited")
                with contextlib.suppress(ValueError):
                    return dict(json.loads(line))

    async def ask(self, **cmd: Any) -> dict[str, Any]:
        self.send(**cmd)
        return await self.recv()

    async def stop(self) -> None:
        with contextlib.suppress(Exception):
            self.send(cmd="quit")
            assert self.proc.stdin is not None
            self.proc.stdin.close()
        try:
            async with asyncio.timeout(10):
                await self.proc.wait()
        except TimeoutError:
            self.proc.kill()
            await self.proc.wait()


async def measure_mesh(size: int) -> dict[str, Any]:
    procs: list[Proc] = []
    try:
        seed = await Proc.start("--worker", "w0", "--index", "0")
        procs.append(seed)
        address = (await seed.recv())["ready"]
        for i in range(1, size):
            args = ["--worker", f"w{i}", "--index", str(i), "--join", address]
            procs.append(await Proc.start(*args))
        for proc in procs[1:]:
            await proc.recv()
        await asyncio.gather(*(p.ask(cmd="peers", n=size - 1) for p in procs))
        await asyncio.sleep(0.5)  # let the initial property exchange settle

        seed.send(cmd="fanout", count=FANOUT_COUNT, gap=FANOUT_GAP)
        sent = (await seed.recv())["sent"]
        await asyncio.sleep(0.5)
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
            "size": size,
            "fan_p50": percentile(latencies, 50),
            "fan_p99": percentile(latencies, 99),
            "fan_delivered": delivered,
            "setup_p50": percentile(times, 50),
            "setup_p99": percentile(times, 99),
            "recv_per_node": statistics.mean(received),
            "recv_min": min(received),
            "sent_per_node": statistics.mean(r["sent"] for r in results) / BLAST_SECONDS,
            "drops": sum(r["drops"] for r in results),
            "payload_per_frame": wire["property_bytes"] / max(1, wire["property_frames"]),
        }
    finally:
        await asyncio.gather(*(p.stop() for p in procs))


def position_frame() -> bytes:
    """A typical position update: metres with millimetre precision, a hull length."""
    return codec.encode(PropertyUpdate(12_345, {"position": (42.137, 17.5), "hull_length": 3.2}))


def ws_bytes(payload: bytes, *, mask: bool) -> int:
    return len(Frame(Opcode.BINARY, payload).serialize(mask=mask, extensions=[]))


async def coordinate(sizes: list[int]) -> None:
    payload = position_frame()
    echo = await Proc.start("--echo-server")
    try:
        floor = await measure_floor((await echo.recv())["ready"], payload)
    finally:
        await echo.stop()
    rows = []
    for size in sizes:
        print(f"measuring {size} nodes ...", file=sys.stderr)
        rows.append(await measure_mesh(size))

    ms = 1000.0
    server_frame, client_frame = ws_bytes(payload, mask=False), ws_bytes(payload, mask=True)
    table = markdown_table(
        [
            "nodes", "fan-out p50 ms", "fan-out p99 ms", "delivered", "setup p50 ms",
            "setup p99 ms", "updates recv/s per node (min)", "updates sent/s per node",
            "queue drops", "bytes per property frame",
        ],
        [
            [
                r["size"], f"{r['fan_p50'] * ms:.3f}", f"{r['fan_p99'] * ms:.3f}",
                f"{r['fan_delivered']:.1%}", f"{r['setup_p50'] * ms:.2f}",
                f"{r['setup_p99'] * ms:.2f}",
                f"{r['recv_per_node']:,.0f} ({r['recv_min']:,.0f})",
                f"{r['sent_per_node']:,.0f}", r["drops"], f"{r['payload_per_frame']:.1f}",
            ]
            for r in rows
        ],
    )  # fmt: skip
    floor_table = markdown_table(
        ["plain websockets, same payload", "value"],
        [
            ["echo round trip p50", f"{floor['rtt_p50'] * ms:.3f} ms"],
            ["echo round trip p99", f"{floor['rtt_p99'] * ms:.3f} ms"],
            ["one process sending to another", f"{floor['rate']:,.0f} messages/s"],
        ],
    )
    by_size = {r["size"]: r for r in rows}
    verdicts = []
    ref = by_size.get(10) or rows[-1]
    setup = ref["setup_p50"] * ms
    verdicts.append(
        f"- session setup p50 < 2 ms with {ref['size']} nodes: {setup:.2f} ms — "
        + ("met" if setup < 2 else f"missed by {setup - 2:.2f} ms ({setup / 2:.1f}x the goal)")
    )
    verdicts.append(
        f"- position update <= 32 bytes on the wire: {len(payload)} bytes of payload, "
        f"{server_frame} bytes as a WebSocket frame from the listening side, {client_frame} "
        "from the dialing side (masked) — "
        + ("met" if client_frame <= 32 else f"missed by {client_frame - 32} bytes")
    )
    for r in rows:
        ratio = r["fan_p50"] / floor["rtt_p50"]
        verdicts.append(
            f"- fan-out p50 within 3x the plain-websockets round trip, {r['size']} nodes: "
            f"{ratio:.1f}x — "
            + ("met" if ratio <= 3 else f"missed ({ratio / 3:.1f}x over the goal)")
        )
    for r in rows:
        recv = r["recv_per_node"]
        verdicts.append(
            f"- >= 30k property updates/s received per node, {r['size']} nodes: {recv:,.0f}/s — "
            + ("met" if recv >= 30_000 else f"missed by {30_000 - recv:,.0f}/s")
        )
    body = "\n\n".join(
        [
            f"Loopback, one process per node, {os.cpu_count()} CPUs shared by every process. "
            f"Fan-out: one node publishes {FANOUT_COUNT} position updates {FANOUT_GAP * ms:g} ms "
            "apart; latency from `update_node_property` to the observer callback on each "
            "other node (`delivered` = share of updates every node saw). Session setup: "
            f"{SESSIONS} sessions in a row, `start_interaction` until `in_group` from every "
            f"other node. Throughput: every node publishes as fast as it can for "
            f"{BLAST_SECONDS:g} s; received = position updates observed from the others.",
            table,
            floor_table,
            "Goals (issue 4):\n" + "\n".join(verdicts),
        ]
    )
    title = "WebSocket mesh (loopback, node processes)"
    publish("mesh", title, body, ".venv/bin/python bench/mesh.py")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sizes", default="2,10,20")
    parser.add_argument("--worker")
    parser.add_argument("--index", type=int, default=0)
    parser.add_argument("--join", action="append", default=[])
    parser.add_argument("--echo-server", action="store_true")
    args = parser.parse_args()
    if args.worker:
        asyncio.run(run_worker(args.worker, args.index, args.join))
    elif args.echo_server:
        asyncio.run(run_echo_server())
    else:
        asyncio.run(coordinate([int(s) for s in args.sizes.split(",")]))


if __name__ == "__main__":
    main()
