"""Threads and tasks writing and taking 100k tuples: nothing lost, nothing taken twice."""

from __future__ import annotations

import asyncio
import threading
from typing import Any

from tuplespace import ANY, TupleSpace

TOTAL = 100_000
THREADS = 8  # 4 writers, 4 takers
TASKS = 100  # 50 writers, 50 takers
# Threads and tasks each write half and take half, so tasks take what threads wrote
# and the other way round.
PER_THREAD = TOTAL // 2 // (THREADS // 2)
PER_TASK = TOTAL // 2 // (TASKS // 2)


async def test_threads_and_tasks_lose_nothing_and_take_nothing_twice() -> None:
    space = TupleSpace()
    taken: list[list[tuple[Any, ...]]] = []
    errors: list[BaseException] = []

    def write(first: int) -> None:
        for i in range(first, first + PER_THREAD):
            space.out(("job", i))

    def take() -> None:
        mine: list[tuple[Any, ...]] = []
        taken.append(mine)
        try:
            for _ in range(PER_THREAD):
                mine.append(space.in_(("job", ANY), timeout=60))
        except BaseException as exc:  # reported by the assertion below
            errors.append(exc)

    async def awrite(first: int) -> None:
        for i in range(first, first + PER_TASK):
            space.out(("job", i))
            if i % 50 == 0:
                await asyncio.sleep(0)

    async def atake() -> list[tuple[Any, ...]]:
        return [await space.ain(("job", ANY), timeout=60) for _ in range(PER_TASK)]

    threads = [threading.Thread(target=take) for _ in range(THREADS // 2)]
    threads += [
        threading.Thread(target=write, args=(TOTAL // 2 + n * PER_THREAD,))
        for n in range(THREADS // 2)
    ]
    for thread in threads:
        thread.start()
    async with asyncio.TaskGroup() as group:
        takers = [group.create_task(atake()) for _ in range(TASKS // 2)]
        for n in range(TASKS // 2):
            group.create_task(awrite(n * PER_TASK))
    for thread in threads:
        await asyncio.to_thread(thread.join, 60)

    assert not errors
    numbers = [tup[1] for mine in taken for tup in mine]
    numbers += [tup[1] for task in takers for tup in task.result()]
    assert len(numbers) == TOTAL
    assert sorted(numbers) == list(range(TOTAL))
    assert len(space) == 0
    assert not space._waiters
