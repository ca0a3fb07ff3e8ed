"""The test process's side of a puppet node process: its mirrored state, read
synchronously by the scenarios, and a pool of processes started ahead of need.

A reader thread queues each JSON line the process prints; ``drain()`` applies them in
order, so the mirror changes only when the harness drains it (never in the middle of a
scenario's predicate) and always to a state the node was in.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import IO, Any

from objectplaces.groups import GroupDefinition
from tests.conformance.roles import RecorderEntry, RecorderLog, heard_in
from tests.mesh.procs import ROOT

Event = dict[str, Any]
PUPPET = ["-m", "tests.conformance.puppet"]


class LineProcess:
    """A child process that prints one JSON object per line; stdin stays open to it."""

    def __init__(self, args: Sequence[str]) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, *args],
            cwd=ROOT,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        self.born = time.monotonic()
        self.events: deque[Event] = deque()
        self.stderr: deque[str] = deque(maxlen=40)
        assert self.proc.stdout is not None
        assert self.proc.stderr is not None
        self._threads = [
            threading.Thread(target=self._read, args=(self.proc.stdout, True), daemon=True),
            threading.Thread(target=self._read, args=(self.proc.stderr, False), daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    def _read(self, pipe: IO[bytes], json_lines: bool) -> None:
        for raw in pipe:
            if json_lines:
                try:
                    self.events.append(json.loads(raw))
                except ValueError:
                    self.stderr.append(f"(stdout) {raw.decode(errors='replace').rstrip()}")
            else:
                self.stderr.append(raw.decode(errors="replace").rstrip())

    def send(self, **command: Any) -> None:
        """Write one JSON command line."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(command).encode() + b"\n")
        self.proc.stdin.flush()

    def end_input(self) -> None:
        """Close stdin: the child sees the end of its input."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            with contextlib.suppress(OSError):
                self.proc.stdin.close()

    @property
    def running(self) -> bool:
        """True while the process has not exited."""
        return self.proc.poll() is None

    def kill(self) -> None:
        """SIGKILL the process (no goodbye of any kind)."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)

    def reap(self, timeout: float) -> None:
        """Wait up to ``timeout`` s for the exit (then kill), and release the pipes."""
        self.end_input()
        try:
            self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)
        for thread in self._threads:
            thread.join(timeout=5)
        for pipe in (self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                pipe.close()

    def describe(self) -> str:
        """Exit status and the last lines of stderr, for a failure message."""
        tail = "\n".join(self.stderr)
        return f"exit status {self.proc.poll()}, stderr:\n{tail}"


class TickerMirror:
    """A participant ``Ticker`` in a puppet: its log."""

    def __init__(self) -> None:
        self.log: list[str] = []


class RecorderMirror:
    """An initiator ``Recorder`` in a puppet: its log and its members."""

    def __init__(self) -> None:
        self.log: list[RecorderEntry] = []
        self.session_id = ""
        self.members: set[str] = set()

    def members_now(self) -> set[str]:
        """The ids of the members the puppet last reported."""
        return set(self.members)

    def heard(self, node: str, what: str) -> bool:
        """True once ``node`` sent a message containing ``what``."""
        return heard_in(self.log, node, what)


class PuppetNode:
    """A node in a puppet process, as the scenarios see it."""

    def __init__(self, process: LineProcess) -> None:
        self.process = process
        self.node_id = ""
        self.address: str | None = None
        self.peers: list[str] = []
        self.dropped = 0
        self.closed = False
        self.killed = False
        self._view: dict[str, dict[str, Any]] = {}
        self._counts: dict[str, int] = {}
        self._recorders: dict[str, RecorderMirror] = {}
        self._started: dict[int, RecorderMirror] = {}
        self._tickers: list[TickerMirror] = []

    def start_node(self, node_id: str, transport: str, secret: bytes, **options: Any) -> None:
        """Start the node in the process (``ready`` sets ``address``)."""
        self.node_id = node_id
        self.process.send(
            cmd="node", id=node_id, transport=transport, secret=secret.hex(), options=options
        )

    def drain(self) -> None:
        """Apply every line the process printed so far.

        Raises:
            AssertionError: the process reported an error, or exited unasked.
        """
        events = self.process.events
        while events:
            self._apply(events.popleft())
        if not self.closed and not self.killed and not self.process.running and not events:
            self.drain_tail()

    def drain_tail(self) -> None:
        """The process exited: apply its last lines, fail unless it said ``closed``."""
        self.process.reap(timeout=5)
        events = self.process.events
        while events:
            self._apply(events.popleft())
        if not self.closed and not self.killed:
            raise AssertionError(f"{self.node_id}: exited unasked; {self.process.describe()}")

    def _apply(self, event: Event) -> None:
        match event["event"]:
            case "state":
                self._apply_state(event)
            case "ready":
                self.address = event["address"]
            case "started":
                mirror = self._started[event["ref"]]
                mirror.session_id = event["session"]
                self._recorders[mirror.session_id] = mirror
            case "closed":
                self.closed = True
            case _:
                raise AssertionError(f"{self.node_id}: {event}; {self.process.describe()}")

    def _apply_state(self, state: Event) -> None:
        if "view" in state:
            self._view = {
                node: {k: tuple(v) if k == "position" else v for k, v in props.items()}
                for node, props in state["view"].items()
            }
        self._counts = state.get("counts", self._counts)
        self.peers = state.get("peers", self.peers)
        self.dropped = state.get("dropped", self.dropped)
        for sid, members in state.get("members", {}).items():
            self._recorders[sid].members = set(members)
        for key, entries in state["logs"].items():
            kind, _, name = key.partition(" ")
            if kind == "r":
                self._recorders[name].log.extend(tuple(e) for e in entries)
            else:
                while len(self._tickers) <= int(name):
                    self._tickers.append(TickerMirror())
                self._tickers[int(name)].log.extend(entries)

    def update_node_property(self, name: str, value: Any) -> None:
        """Set one of the node's properties."""
        self.process.send(cmd="set", name=name, value=value)

    def view(self) -> Mapping[str, Mapping[str, Any]]:
        """The node's view, as last reported."""
        return self._view

    def state_counts(self) -> Mapping[str, int]:
        """``machine.state_counts()``, as last reported."""
        return self._counts

    def serve(self, role: str) -> list[TickerMirror]:
        """Play ``role`` with a ``Ticker``; returns the tickers it will activate."""
        assert role == "ticker", "a puppet plays only the ticker role"
        self.process.send(cmd="serve", role=role)
        return self._tickers

    async def start_interaction(self, definition: GroupDefinition, role: str) -> RecorderMirror:
        """Start a session with a ``Recorder``; returns its mirror once the session has an id."""
        ref = len(self._started)
        recorder = self._started[ref] = RecorderMirror()
        self.process.send(cmd="start", ref=ref, definition=definition.to_json(), role=role)
        await poll([self], lambda: bool(recorder.session_id), within=10)
        return recorder

    def stop_interaction(self, recorder: RecorderLog) -> None:
        """Stop a session this node started."""
        self.process.send(cmd="stop", session=recorder.session_id)

    def __repr__(self) -> str:
        return f"<PuppetNode {self.node_id!r} at {self.address}>"


class PuppetPool:
    """Puppet processes started ahead of need, so that a scenario's nodes start in
    parallel with whatever runs before them. A process whose node left is used again
    (for at most ``max_age`` seconds); others exit in the background. ``close()`` ends
    every process the pool ever started."""

    def __init__(self, spares: int = 4, max_age: float = 120.0) -> None:
        self.spares = spares
        self.max_age = max_age
        self._idle: deque[LineProcess] = deque()
        self._spawned: list[LineProcess] = []
        self._fill()

    def _spawn(self) -> LineProcess:
        self._spawned.append(LineProcess(PUPPET))
        return self._spawned[-1]

    def _fill(self) -> None:
        while len(self._idle) < self.spares:
            self._idle.append(self._spawn())

    def _usable(self, process: LineProcess) -> bool:
        return process.running and time.monotonic() - process.born < self.max_age

    def take(self) -> PuppetNode:
        """A started process with no node."""
        while self._idle and not self._usable(self._idle[0]):
            self._idle.popleft().end_input()
        process = self._idle.popleft() if self._idle else self._spawn()
        self._fill()
        return PuppetNode(process)

    def give_back(self, node: PuppetNode) -> None:
        """Take back the process of a node that left (``closed``); retire any other."""
        process = node.process
        reusable = node.closed and not node.killed and not process.events
        if reusable and self._usable(process) and len(self._idle) < max(2 * self.spares, 1):
            self._idle.append(process)
        else:
            self.retire(node)

    def retire(self, node: PuppetNode) -> None:
        """Let a puppet's node leave and the process exit (stdin ends), without waiting."""
        node.process.end_input()

    def close(self) -> None:
        """End every process, waiting a bounded time for each."""
        self._idle.clear()
        for process in self._spawned:
            process.end_input()
        for process in self._spawned:
            process.reap(timeout=10)
        self._spawned.clear()


async def poll(nodes: Iterable[PuppetNode], predicate: Callable[[], bool], within: float) -> None:
    """Drain ``nodes`` until ``predicate()`` holds; fail after ``within`` seconds."""
    nodes = list(nodes)
    deadline = time.monotonic() + within
    while True:
        for node in nodes:
            node.drain()
        if predicate():
            return
        if time.monotonic() > deadline:
            seen = "\n".join(f"{n!r}: peers {n.peers}; {n.process.describe()}" for n in nodes)
            raise AssertionError(f"not within {within}s\n{seen}")
        await asyncio.sleep(0.005)
