"""A control that runs only a task desk on an order store, for the restart tests.

``python -m tests.agv_app.tasks.order_control STORE --join HOST:PORT ...`` opens the
store (exit status 2 and the refusal on stderr if it cannot), runs the transport base on
the mesh (plain links on loopback, joining the vehicles' nodes), prints ``ready``, then
reads commands on stdin: ``create PICK DROP`` answers ``ok TASK_ID`` once the task is on
disk; ``open`` answers ``open`` and the ids of the open tasks; ``quit`` closes the store
and leaves. End of input is a ``quit`` too.
"""

from __future__ import annotations

import argparse
import asyncio
import random
import sys

from agv_app.layout.demo import demo_warehouse
from agv_app.tasks.desk import BASE_ID, TaskDesk
from agv_app.tasks.store import OrderStore, StoreError
from objectplaces.mesh import start_mesh_node
from tests.credentials import TEST_SECRET

STATIONS = ("dock-in-1", "dock-in-2")


async def run(args: argparse.Namespace) -> int:
    try:
        store = OrderStore.open(args.store)
    except StoreError as exc:
        print(f"order_control: {exc}", file=sys.stderr, flush=True)
        return 2
    loop = asyncio.get_running_loop()
    started = loop.time()
    desk = TaskDesk(
        demo_warehouse(),
        rng=random.Random(1),
        clock=lambda: loop.time() - started,
        store=store,
        hand_back_after=args.grace,
    )
    node = await start_mesh_node(BASE_ID, join=args.join, insecure=True, secret=TEST_SECRET)
    desk.open_base(node, STATIONS)
    reader = asyncio.StreamReader()
    await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    print("ready", flush=True)
    while line := (await reader.readline()).decode():
        words = line.split()
        if words[:1] == ["create"]:
            print(f"ok {desk.create(words[1], words[2])}", flush=True)
        elif words[:1] == ["open"]:
            print(f"open {' '.join(desk.book.open_ids())}".strip(), flush=True)
        elif words[:1] == ["quit"]:
            break
    await node.close()
    store.close()
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(prog="order_control")
    parser.add_argument("store")
    parser.add_argument("--join", action="append", default=[])
    parser.add_argument("--grace", type=float, default=30.0)
    return asyncio.run(run(parser.parse_args()))


if __name__ == "__main__":
    sys.exit(main())
