"""Node processes for the tests: start ``objectplaces node``, read its JSON events, drive it.

Every process is bounded (``--run-seconds``) and exits by itself; ``Cluster.close`` kills
whatever is left. Waits are bounded and fail with the events seen so far.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
Event = dict[str, Any]


class NodeProcess:
    """One ``objectplaces node`` process with ``--control``."""

    def __init__(
        self,
        node_id: str,
        credentials: list[str],
        args: list[str],
        run_seconds: float,
        prefix: list[str] | None = None,
    ):
        self.node_id = node_id
        command = [
            *(prefix or []),
            sys.executable, "-m", "objectplaces.node_cli",
            "--id", node_id,
            *credentials,
            "--control",
            "--run-seconds", str(run_seconds),
            "--log-level", "INFO",
            *args,
        ]  # fmt: skip
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen(
            command,
            cwd=ROOT,
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        self.events: list[Event] = []
        self.stderr: list[str] = []
        self._cond = threading.Condition()
        self._threads = [
            threading.Thread(target=self._read_stdout, daemon=True),
            threading.Thread(target=self._read_stderr, daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    def _read_stdout(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            try:
                event = json.loads(raw)
            except ValueError:
                event = {"event": "garbage", "line": raw.decode(errors="replace")}
            with self._cond:
                self.events.append(event)
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        for raw in self.proc.stderr:
            with self._cond:
                self.stderr.append(raw.decode(errors="replace").rstrip())
                self._cond.notify_all()

    def send(self, **command: Any) -> None:
        """Send one control command."""
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps(command).encode() + b"\n")
        self.proc.stdin.flush()

    def wait_for(
        self, predicate: Callable[[Event], bool], *, timeout: float = 20.0, since: int = 0
    ) -> Event:
        """The first event from index ``since`` on that satisfies ``predicate``."""
        deadline = time.monotonic() + timeout
        index = since
        with self._cond:
            while True:
                while index < len(self.events):
                    event = self.events[index]
                    index += 1
                    if predicate(event):
                        return event
                remaining = deadline - time.monotonic()
                if remaining <= 0 or (self.proc.poll() is not None and index >= len(self.events)):
                    break
                self._cond.wait(min(remaining, 0.5))
        tail = "\n".join(self.stderr[-20:])
        raise AssertionError(
            f"{self.node_id}: no matching event within {timeout}s; events: {self.events[-30:]}"
            f"\nstderr tail:\n{tail}"
        )

    def wait_event(
        self, name: str, *, timeout: float = 20.0, since: int = 0, **fields: Any
    ) -> Event:
        """The first event called ``name`` with these field values."""
        return self.wait_for(
            lambda e: e.get("event") == name and all(e.get(k) == v for k, v in fields.items()),
            timeout=timeout,
            since=since,
        )

    def wait_stderr(self, text: str, *, timeout: float = 20.0) -> str:
        """The first stderr line containing ``text``."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                for line in self.stderr:
                    if text in line:
                        return line
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise AssertionError(f"{self.node_id}: no {text!r} on stderr: {self.stderr}")
                self._cond.wait(min(remaining, 0.5))

    def wait_peers(self, count: int, *, timeout: float = 20.0) -> Event:
        """Wait until the node reports at least ``count`` linked peers."""
        return self.wait_for(
            lambda e: e.get("event") == "peers" and len(e["peers"]) >= count, timeout=timeout
        )

    @property
    def address(self) -> str:
        """Where the node listens (waits for it to be ready)."""
        return str(self.wait_event("ready")["address"])

    def kill(self) -> None:
        """SIGKILL the process."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=10)

    def quit(self, *, timeout: float = 15.0) -> int:
        """Ask the node to leave and exit; returns its exit status."""
        if self.proc.poll() is None:
            with contextlib.suppress(BrokenPipeError, OSError):
                self.send(cmd="quit")
        return self.proc.wait(timeout=timeout)

    def close(self) -> None:
        """Make sure the process is gone and its pipes are closed."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(timeout=10)
        for thread in self._threads:
            thread.join(timeout=5)
        for pipe in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            if pipe is not None:
                with contextlib.suppress(OSError):
                    pipe.close()


class Cluster:
    """Node processes of one mesh; ``close()`` kills what is left.

    Args:
        secret_file: plain links on loopback, proven by the secret in this file.
        pki: mutual TLS instead, each node with its certificate in this PKI folder.
    """

    def __init__(
        self,
        secret_file: Path | None = None,
        *,
        pki: Path | None = None,
        run_seconds: float = 60.0,
    ):
        assert (secret_file is None) != (pki is None), "a secret file or a PKI folder"
        self.secret_file = secret_file
        self.pki = pki
        self.run_seconds = run_seconds
        self.nodes: list[NodeProcess] = []

    def start(
        self,
        node_id: str,
        *args: str,
        secret_file: Path | None = None,
        pki: Path | None = None,
        prefix: list[str] | None = None,
    ) -> NodeProcess:
        """Start one node process (with the cluster's credentials unless others are given;
        ``prefix`` runs it inside another command, e.g. ``ip netns exec``)."""
        pki = pki or (None if secret_file else self.pki)
        if pki is not None:
            credentials = ["--pki", str(pki)]
        else:
            credentials = ["--insecure", "--secret-file", str(secret_file or self.secret_file)]
        node = NodeProcess(node_id, credentials, list(args), self.run_seconds, prefix)
        self.nodes.append(node)
        return node

    def close(self) -> None:
        """Kill every process still running."""
        for node in self.nodes:
            node.close()
