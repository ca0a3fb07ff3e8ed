"""What every node on a real network shares, whatever carries its frames: the
``RoleActivator`` API, an asyncio runner, and why and when it left the network.

``MeshNode`` (the WebSocket mesh) and ``ZenohNode`` build on it.
"""

from __future__ import annotations

import asyncio
from types import TracebackType
from typing import Self

from objectplaces.activator import RoleActivator
from objectplaces.core.node import NodeMachine
from objectplaces.runtime.aio import AsyncioRunner
from objectplaces.transport.options import PeerStats
from tuplespace import TupleSpace

__all__ = ["NetworkNode"]


class NetworkNode(RoleActivator):
    """A node on a real network; ``await node.close()`` (or ``async with``) leaves it."""

    def __init__(self, machine: NodeMachine, *, runner: AsyncioRunner, space: TupleSpace) -> None:
        super().__init__(machine, clock=runner.now, wake=runner.wake, space=space)
        self._runner = runner
        self._close_reason: str | None = None
        self._closed_event = asyncio.Event()

    @property
    def closed(self) -> bool:
        """Whether the node is off the network: ``close()`` was called, or it stopped."""
        return self._close_reason is not None

    @property
    def close_reason(self) -> str | None:
        """Why the node is off the network (None while it is on it)."""
        return self._close_reason

    async def wait_closed(self) -> str:
        """Wait until the node is off the network, for any reason; returns the reason."""
        await self._closed_event.wait()
        assert self._close_reason is not None
        return self._close_reason

    def _mark_closed(self, reason: str, *, settled: bool = True) -> bool:
        """Record why the node is off the network; False if that was known already.

        ``settled=False`` leaves ``wait_closed`` waiting until ``_settle_closed()``.
        """
        if self._close_reason is not None:
            return False
        self._close_reason = reason
        if settled:
            self._settle_closed()
        return True

    def _settle_closed(self) -> None:
        """Wake ``wait_closed``: whatever closing had to finish has finished."""
        self._closed_event.set()

    def peers(self) -> list[str]:
        """Ids of the other nodes this node is in touch with now, sorted."""
        raise NotImplementedError

    def peer_stats(self) -> dict[str, PeerStats]:
        """Per-peer link counters, by peer id (empty where the transport keeps no links)."""
        raise NotImplementedError

    def transport_counters(self) -> dict[str, int]:
        """Node-wide transport counters (frames in and out, drops by reason ...)."""
        raise NotImplementedError

    async def links_changed(self) -> None:
        """Wait until a peer comes or goes."""
        raise NotImplementedError

    async def wait_for_peers(self, count: int) -> list[str]:
        """Wait until at least ``count`` peers are in touch (bound it with ``asyncio.timeout``)."""
        while len(self.peers()) < count:
            await self.links_changed()
        return self.peers()

    async def close(self) -> None:
        """Leave the network (each transport's node says how)."""
        raise NotImplementedError

    async def __aenter__(self) -> Self:
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()
