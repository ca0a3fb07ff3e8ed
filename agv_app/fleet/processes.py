"""The AGV processes of a mesh fleet: spawned, watched and reaped, all on 127.0.0.1.

Each AGV runs ``python -m agv_app.fleet.agv_process`` in its own session; the children's
output goes to files in a temporary directory of the run, which only its owner can read.
``reap`` gives every child end of file on stdin and SIGTERM, waits a bounded time for
it to leave the mesh, and kills whoever is left; ``close`` removes the directory.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

__all__ = ["AgvProcesses"]

_POLL_S = 0.05
_ROOT = str(Path(__file__).resolve().parents[2])
_MODULE = "agv_app.fleet.agv_process"


class AgvProcesses:
    """The AGV processes of one run, and the directory that holds their logs.

    Args:
        python: the interpreter that runs them.
        capture_output: keep the children's stdout and stderr off this process's
            terminal (they go to files in the run's directory).
    """

    def __init__(self, *, python: str, capture_output: bool = True) -> None:
        self.python = python
        self.capture_output = capture_output
        self._children: list[tuple[str, subprocess.Popen[bytes]]] = []
        self._tmpdir: Path | None = None

    def open_run_dir(self) -> Path:
        """Create the run's directory (mode 0700: the logs are the owner's alone)."""
        self._tmpdir = Path(tempfile.mkdtemp(prefix="objectplaces-mesh-"))
        return self._tmpdir

    def spawn(self, agv_id: str, arguments: list[str]) -> None:
        """Start the AGV process ``agv_id`` with the command-line ``arguments``."""
        command = [self.python, "-m", _MODULE, "--id", agv_id, *arguments]
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        env["PYTHONPATH"] = os.pathsep.join(p for p in (_ROOT, env.get("PYTHONPATH")) if p)
        out: Any = None
        if self.capture_output and self._tmpdir is not None:
            out = open(self._tmpdir / f"{agv_id}.log", "wb")  # noqa: SIM115 (closed below)
        try:
            # Its own session: a Ctrl-C at the terminal reaches the dashboard only, and
            # the dashboard stops its children in order. The stdin pipe stays open for
            # the child's whole life; its end of file tells the child we are gone.
            proc = subprocess.Popen(
                command,
                env=env,
                stdin=subprocess.PIPE,
                stdout=out if out is not None else subprocess.DEVNULL,
                stderr=out if out is not None else None,
                start_new_session=True,
                close_fds=True,
            )
        finally:
            if out is not None:
                out.close()
        self._children.append((agv_id, proc))

    def pids(self) -> list[int]:
        """Process ids of the processes spawned (running or not)."""
        return [proc.pid for _, proc in self._children]

    def exit_codes(self) -> dict[str, int | None]:
        """Each process's exit status, by AGV id (None: still running)."""
        return {agv_id: proc.poll() for agv_id, proc in self._children}

    def exited(self) -> list[str]:
        """Ids of the AGVs whose process has exited."""
        return [agv_id for agv_id, proc in self._children if proc.poll() is not None]

    def running(self) -> int:
        """How many processes are still running."""
        return sum(proc.poll() is None for _, proc in self._children)

    def logs(self) -> dict[str, str]:
        """The captured output of every process so far (for diagnostics)."""
        out: dict[str, str] = {}
        if self._tmpdir is None:
            return out
        for agv_id, _ in self._children:
            with contextlib.suppress(OSError):
                out[agv_id] = (self._tmpdir / f"{agv_id}.log").read_text(errors="replace")
        return out

    async def reap(self, grace_s: float) -> None:
        """End every process: end of file and SIGTERM, ``grace_s`` seconds, then SIGKILL."""
        children = [proc for _, proc in self._children]
        for proc in children:
            if proc.stdin is not None:
                with contextlib.suppress(OSError):
                    proc.stdin.close()
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for _ in range(math.ceil(grace_s / _POLL_S) + 1):
            if all(p.poll() is not None for p in children) or time.monotonic() >= deadline:
                break
            await asyncio.sleep(_POLL_S)
        for proc in children:
            if proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    proc.kill()
        for proc in children:
            # After SIGKILL the wait is short; bounded all the same.
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=5.0)

    def close(self) -> None:
        """Remove the run's directory and the logs in it."""
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None
