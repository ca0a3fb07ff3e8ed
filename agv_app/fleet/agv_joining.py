"""How an AGV process joins its fleet: it opens its Zenoh session (trying again while
no router or peer can be reached) and waits, bounded, for the peers it expects; a fleet
that runs another layout refuses it (:class:`AnotherFleet`).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import math
import sys
from typing import Any

from agv_app.fleet.agv_events import emit, who
from objectplaces.mesh import MeshNode
from objectplaces.security import Credentials
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node

__all__ = ["AnotherFleet", "open_zenoh", "settle"]

_SETTLE_REPORT_S = 10.0
_RETRY_FIRST_S = 0.5
_RETRY_MAX_S = 10.0


class AnotherFleet(Exception):
    """The peers this process reached run another layout: it may not join them."""


async def settle(node: MeshNode | ZenohNode, args: argparse.Namespace) -> None:
    """Wait (bounded by ``--settle-timeout``) until the expected peers are linked and
    have been heard, saying every ``_SETTLE_REPORT_S`` what it waits for.

    Moving earlier is safe (the requester waits the safe time for late members), but
    an AGV that has not yet heard its neighbours would ask fewer of them than it should.

    Raises:
        AnotherFleet: a peer refused our link for running another layout.
    """
    loop = asyncio.get_running_loop()
    deadline = loop.time() + (math.inf if args.settle_timeout is None else args.settle_timeout)
    while len(node.peers()) < args.expect_peers and loop.time() < deadline:
        refusals = node.refusals()
        foreign = [f"{where}: {why}" for where, why in refusals.items() if "another fleet" in why]
        if foreign:
            raise AnotherFleet("; ".join(foreign))
        emit(
            "waiting",
            peers=node.peers(),
            expected=args.expect_peers,
            connect=[*args.join, *args.connect],
            refusals=refusals,
        )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(min(_SETTLE_REPORT_S, max(0.0, deadline - loop.time()))):
                await node.wait_for_peers(args.expect_peers)
    await asyncio.sleep(args.t_update)


async def open_zenoh(
    args: argparse.Namespace,
    credentials: Credentials,
    tag: str,
    timing: dict[str, Any],
    stop: asyncio.Event,
) -> ZenohNode | None:
    """Open the node's Zenoh session; while no router or peer of ``--connect`` can be
    reached, say so and try again, backing off up to ``_RETRY_MAX_S`` (None: told to
    stop meanwhile)."""
    delay = _RETRY_FIRST_S
    while True:
        try:
            return await start_zenoh_node(
                args.id,
                tls=credentials.tls,
                insecure=credentials.insecure,
                secret=credentials.secret,
                connect=args.connect,
                mode=args.mode,
                poll_interval=args.poll_interval or None,
                tag=tag,
                **timing,
            )
        except OSError as exc:
            emit("unreachable", connect=args.connect, error=str(exc), retry_in_s=delay)
            print(
                f"{who(args)}: cannot reach {', '.join(args.connect)} yet ({exc}); "
                f"trying again in {delay:g} s",
                file=sys.stderr,
            )
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(delay):
                await stop.wait()
                return None
        delay = min(_RETRY_MAX_S, delay * 2)
