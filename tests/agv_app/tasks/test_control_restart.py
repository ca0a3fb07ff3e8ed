"""A real control process killed with SIGKILL mid-run and started again on its order
store: every order it acknowledged is carried out, none twice; a second control on the
same store is refused while the first runs."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from collections import Counter
from pathlib import Path

import pytest

from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.store import OrderStore
from objectplaces.mesh import MeshNode, start_mesh_node
from tests.agv_app.tasks.fake_agvs import FakeAgv
from tests.credentials import TEST_SECRET
from tests.waiting import until

CARRY_S = 2.0
ORDERS = 8


class CarryingAgv(FakeAgv):
    """Delivers each task ``CARRY_S`` after it took it, whoever listens."""

    def take(self, task: TaskSpec) -> None:
        super().take(task)
        self.node.call_later(CARRY_S, self.deliver)


class ControlProcess:
    """``tests.agv_app.tasks.order_control`` on a store, joining the vehicles."""

    def __init__(self, proc: asyncio.subprocess.Process) -> None:
        self.proc = proc

    @classmethod
    async def start(cls, store: Path, join: list[str]) -> ControlProcess:
        args = [a for address in join for a in ("--join", address)]
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            "-m",
            "tests.agv_app.tasks.order_control",
            str(store),
            *args,
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.PIPE,
        )
        return cls(proc)

    async def line(self) -> str:
        assert self.proc.stdout is not None
        async with asyncio.timeout(60):
            line = (await self.proc.stdout.readline()).decode().strip()
        if not line:
            assert self.proc.stderr is not None
            raise AssertionError(f"control ended: {(await self.proc.stderr.read()).decode()}")
        return line

    async def send(self, command: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(f"{command}\n".encode())
        await self.proc.stdin.drain()

    async def ask(self, command: str) -> str:
        await self.send(command)
        return await self.line()

    async def create(self, pick: str, drop: str) -> str:
        answer = await self.ask(f"create {pick} {drop}")
        assert answer.startswith("ok task-"), answer
        return answer.split()[1]

    def kill(self) -> None:
        if self.proc.returncode is None:
            os.kill(self.proc.pid, signal.SIGKILL)


@pytest.mark.processes
async def test_a_killed_control_resumes_every_acknowledged_order_and_none_twice(
    tmp_path: Path,
) -> None:
    store = tmp_path / "orders.db"
    nodes: list[MeshNode] = []
    controls: list[ControlProcess] = []
    try:
        agvs = []
        for i, spot in enumerate([(9.75, 1.5), (34.75, 1.5), (20.0, 1.5)]):
            nodes.append(await start_mesh_node(f"agv-{i + 1}", insecure=True, secret=TEST_SECRET))
            agvs.append(CarryingAgv(nodes[-1], spot))
        join = [node.address for node in nodes]

        first = await ControlProcess.start(store, join)
        controls.append(first)
        assert await first.line() == "ready"
        acked = [
            await first.create(pick, "dock-out-1")
            for pick in ["dock-in-1", "dock-in-2"] * (ORDERS // 2)
        ]
        assert acked == [f"task-{n}" for n in range(1, ORDERS + 1)]

        def delivered() -> list[str]:
            return [t for agv in agvs for t in agv.delivered]

        # Kill it in the middle: some orders delivered, some held, some not yet awarded.
        await until(lambda: len(delivered()) >= 2 and any(a.held for a in agvs), within=120)
        first.kill()
        assert await first.proc.wait() == -signal.SIGKILL
        assert len(delivered()) < ORDERS

        second = await ControlProcess.start(store, join)
        controls.append(second)
        assert await second.line() == "ready"

        rival = await ControlProcess.start(store, join)
        controls.append(rival)
        assert await rival.proc.wait() == 2
        assert rival.proc.stderr is not None
        refusal = (await rival.proc.stderr.read()).decode()
        assert f"order store {store} is in use by another control (pid {second.proc.pid})" in (
            refusal
        )

        await until(lambda: sorted(delivered()) == sorted(acked), within=180)
        await asyncio.sleep(2 * CARRY_S)  # time for a second delivery of any, were there one
        counts = Counter(delivered())
        assert [t for t, n in counts.items() if n > 1] == []

        # The control hears of the last deliveries, then leaves cleanly.
        for _ in range(600):
            if await second.ask("open") == "open":
                break
            await asyncio.sleep(0.1)
        else:
            raise AssertionError(f"orders still open: {await second.ask('open')}")
        await second.send("quit")
        assert await second.proc.wait() == 0
        with OrderStore.open(store) as reopened:
            rows = reopened.task_rows()
        assert [r["id"] for r in rows] == acked  # none duplicated
        assert {r["id"]: r["state"] for r in rows} == dict.fromkeys(acked, "done")
    finally:
        for control in controls:
            control.kill()
            await control.proc.wait()
        for node in nodes:
            await node.close()
