"""A conformance node in its own process, driven over stdin and mirrored over stdout.

``python -m tests.conformance.puppet`` waits for JSON commands, one per line on stdin:

- ``{"cmd": "node", "id": ..., "transport": "websocket"|"zenoh", "secret": HEX,
  "options": {...}}`` starts a node (the options are ``start_node``'s) and answers
  ``{"event": "ready", "address": ...}``;
- ``{"cmd": "set", "name": ..., "value": ...}`` sets a property;
- ``{"cmd": "serve", "role": ...}`` plays ``role`` with a new ``Ticker`` per activation;
- ``{"cmd": "start", "ref": N, "definition": JSON, "role": ...}`` starts a session with a
  ``Recorder`` and answers ``{"event": "started", "ref": N, "session": ...}``;
- ``{"cmd": "stop", "session": ...}`` stops one;
- ``{"cmd": "leave"}`` lets the node leave and answers ``{"event": "closed"}``; the
  process then waits for its next ``node`` command, a new node with nothing of the last.

While a node runs, it prints ``{"event": "state", ...}`` every 10 ms with what changed
since the last one: ``view``, ``counts`` (``machine.state_counts()``), ``members`` of
each session and ``peers``, ``dropped`` (frames refused), and the new entries of each
recorder and ticker log. A failed command, or a node that closes by itself, prints
``{"event": "error", ...}``. The end of stdin (the test process is gone) lets the node
leave and ends the process; so do ``--run-seconds``, whatever happens.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
from typing import Any

from objectplaces.groups import definition_from_json
from objectplaces.mesh import MeshNode, start_node
from objectplaces.zenoh_node import ZenohNode
from tests.conformance.roles import Recorder, Ticker

STATE_PERIOD = 0.01


def emit(event: str, **fields: Any) -> None:
    """Print one event as a JSON line."""
    sys.stdout.write(json.dumps({"event": event, **fields}, default=repr) + "\n")
    sys.stdout.flush()


class Puppet:
    """One node at a time and the roles it plays, reported as deltas of its state."""

    def __init__(self) -> None:
        self.node: MeshNode | ZenohNode | None = None
        self.forget()

    def forget(self) -> None:
        """Drop every role and report of the last node."""
        self.recorders: dict[str, Recorder] = {}
        self.tickers: list[Ticker] = []
        self.reported: dict[str, Any] = {}
        self.log_marks: dict[str, int] = {}
        self.leaving = False
        self.lost = False

    async def handle(self, command: dict[str, Any]) -> None:
        """Carry out one command."""
        match command["cmd"]:
            case "node":
                await self._start_node(command)
            case "leave":
                await self.leave()
            case other:
                self._on_node(other, command)

    async def _start_node(self, command: dict[str, Any]) -> None:
        assert self.node is None, "a node runs already"
        self.forget()
        self.node = await start_node(
            command["id"],
            transport=command["transport"],
            insecure=True,
            secret=bytes.fromhex(command["secret"]),
            **command["options"],
        )
        emit("ready", address=self.node.address)

    def _on_node(self, cmd: str, command: dict[str, Any]) -> None:
        node = self.node
        assert node is not None, "no node yet"
        if cmd == "set":
            name, value = command["name"], command["value"]
            node.update_node_property(name, tuple(value) if name == "position" else value)
        elif cmd == "serve":
            node.set_participant_factory(command["role"], self._new_ticker)
        elif cmd == "start":
            recorder = Recorder()
            definition = definition_from_json(command["definition"])
            session = node.start_interaction(recorder, definition, command["role"])
            self.recorders[session.session_id] = recorder
            emit("started", ref=command["ref"], session=session.session_id)
        elif cmd == "stop":
            node.stop_interaction(command["session"])
        else:
            raise ValueError(f"unknown command {cmd!r}")

    def _new_ticker(self) -> Ticker:
        self.tickers.append(Ticker())
        return self.tickers[-1]

    def report(self) -> None:
        """Print what changed since the last report, if anything did."""
        node = self.node
        if node is None:
            return
        if node.closed and not self.leaving and not self.lost:
            self.lost = True
            emit("error", error=f"the node closed by itself: {node.close_reason}")
        now: dict[str, Any] = {
            "view": {n: dict(p) for n, p in node.view().items()},
            "counts": node.machine.state_counts(),
            "members": {sid: sorted(r.members_now()) for sid, r in self.recorders.items()},
            "peers": node.peers(),
            "dropped": sum(v for k, v in node.stats().counters.items() if k.startswith("dropped")),
        }
        changed = {k: v for k, v in now.items() if self.reported.get(k) != v}
        self.reported.update(changed)
        logs: dict[str, list[Any]] = {f"r {sid}": r.log for sid, r in self.recorders.items()}
        logs.update({f"t {i}": t.log for i, t in enumerate(self.tickers)})
        entries = {}
        for key, log in logs.items():
            mark = self.log_marks.get(key, 0)
            if len(log) > mark:
                entries[key] = log[mark:]
                self.log_marks[key] = len(log)
        if changed or entries:
            emit("state", logs=entries, **changed)

    async def leave(self) -> None:
        """Let the node leave (the last roles' callbacks are reported) and say so."""
        node = self.node
        if node is None:
            return
        self.leaving = True
        await node.close()
        self.report()
        self.node = None
        emit("closed")


async def _obey(puppet: Puppet) -> None:
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=1 << 20)
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    while line := await reader.readline():
        try:
            await puppet.handle(json.loads(line))
        except Exception as exc:  # any failed command is the scenario's failure, reported
            emit("error", error=f"{type(exc).__name__}: {exc}")
        puppet.report()


async def _report(puppet: Puppet) -> None:
    while True:
        puppet.report()
        await asyncio.sleep(STATE_PERIOD)


async def run(run_seconds: float) -> None:
    """Obey commands until stdin ends or ``run_seconds`` pass; then leave."""
    puppet = Puppet()
    reporter = asyncio.create_task(_report(puppet))
    try:
        async with asyncio.timeout(run_seconds):
            await _obey(puppet)
    except TimeoutError:
        emit("error", error=f"ran out of time ({run_seconds} s)")
    finally:
        reporter.cancel()
        await puppet.leave()


def main() -> None:
    """Parse the arguments and run."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--run-seconds", type=float, default=300.0, help="stop after this")
    args = parser.parse_args()
    asyncio.run(run(args.run_seconds))


if __name__ == "__main__":
    main()
