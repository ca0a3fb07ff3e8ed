"""What stops an AGV process besides its run time and signals: its stdin (a pipe from
its parent) closing, its parent dying, or another process running as its id.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import stat
import sys

from objectplaces.mesh import MeshNode
from objectplaces.zenoh_node import ZenohNode

__all__ = ["watch_parent", "watch_stdin", "watch_twin"]

_PARENT_CHECK_S = 1.0
_TWIN_AFTER_S = 15.0
"""Seconds another run's token of our id may stay up: a crashed run's lasts the lease
(10 s), and then some for a loaded machine."""


async def watch_stdin(stop: asyncio.Event) -> None:
    """Set ``stop`` when stdin, a pipe from the parent, reaches end of file."""
    try:
        if not stat.S_ISFIFO(os.fstat(sys.stdin.fileno()).st_mode):
            return  # a terminal or /dev/null: nobody holds it open for us
    except (OSError, ValueError):
        return
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=1 << 16)
    try:
        transport, _ = await loop.connect_read_pipe(
            lambda: asyncio.StreamReaderProtocol(reader), sys.stdin
        )
    except (OSError, ValueError):
        return
    try:
        while True:
            try:
                line = await reader.readline()
            except ValueError:
                continue  # a line too long: ignored, nothing is read from stdin
            if not line:
                stop.set()
                return
    finally:
        transport.close()


async def watch_twin(node: MeshNode | ZenohNode, args: argparse.Namespace) -> None:
    """Return when another process has run as this vehicle's id past a dead run's
    lease (on Zenoh, where every run holds a token): this one must give way."""
    if not isinstance(node, ZenohNode):
        await asyncio.Event().wait()  # for ever: the mesh keeps the newer run's links
        return
    while True:
        await asyncio.sleep(1.0)
        twin = node.twin_up_for()
        if twin is not None and twin > _TWIN_AFTER_S:
            return


async def watch_parent(stop: asyncio.Event, parent: int) -> None:
    """Set ``stop`` when the parent process is gone (we were re-parented)."""
    while True:
        await asyncio.sleep(_PARENT_CHECK_S)
        if os.getppid() != parent:
            stop.set()
            return
