"""``WS /ws/events``: the live feed, one supervised sender per socket.

Each socket runs two tasks in one task group: the sender, which waits for a state
offered by the driver and sends what the client's ``ClientFeed`` makes of it, and the
watcher, which only waits for the client to leave (clients send nothing). When either
ends, the group cancels the other: a client that leaves stops its sender, and a sender
that dies (an error, or a client too slow to take a message within ``SEND_TIMEOUT_S``)
closes the socket with code 1011 instead of leaving it open and silent. Either way the
client is unregistered from the hub.

The group is anyio's, the one Starlette itself runs on: the server and the test client
end a socket's handler by cancelling an anyio cancel scope, which an anyio group obeys
exactly once, while an ``asyncio.TaskGroup`` inside such a scope may leak the
cancellation out of it.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import Awaitable, Callable

import anyio
from fastapi import APIRouter, WebSocket, WebSocketDisconnect
from starlette.websockets import WebSocketState

from dashboard.deps import State
from dashboard.state import FeedClient

__all__ = ["SEND_TIMEOUT_S", "router"]

log = logging.getLogger(__name__)

router = APIRouter()

SEND_TIMEOUT_S = 10.0
"""Longest a client may take to accept one message before its socket is closed."""


@router.websocket("/ws/events")
async def events(websocket: WebSocket, state: State) -> None:
    """A snapshot, then deltas at most 20 times a second (docs/dashboard.md)."""
    await websocket.accept()
    client = state.connect_feed()
    try:
        async with anyio.create_task_group() as tasks:

            async def until_done(run: Callable[[], Awaitable[None]]) -> None:
                await run()
                tasks.cancel_scope.cancel()

            tasks.start_soon(until_done, lambda: _send(websocket, client))
            tasks.start_soon(until_done, lambda: _watch_for_leaving(websocket))
    except* Exception as failed:
        log.warning("feed sender failed; closing its socket", exc_info=failed)
        await _close(websocket)
    finally:
        state.disconnect_feed(client)


async def _send(websocket: WebSocket, client: FeedClient) -> None:
    loop = asyncio.get_running_loop()
    feed = client.feed
    while True:
        wait = feed.delay(loop.time())
        if wait is None:
            await client.wake.wait()
            client.wake.clear()
            continue
        if wait > 0:
            await asyncio.sleep(wait)
        message = feed.take(loop.time())
        if message is not None:
            text = json.dumps(message, separators=(",", ":"))
            with anyio.fail_after(SEND_TIMEOUT_S):
                try:
                    await websocket.send_text(text)
                except (WebSocketDisconnect, OSError):  # the client vanished mid-send
                    return


async def _watch_for_leaving(websocket: WebSocket) -> None:
    while True:
        message = await websocket.receive()
        if message["type"] == "websocket.disconnect":
            return


async def _close(websocket: WebSocket) -> None:
    if websocket.client_state != WebSocketState.CONNECTED:
        return
    try:
        with anyio.fail_after(SEND_TIMEOUT_S):
            await websocket.close(code=1011, reason="the feed failed")
    except Exception as exc:  # the client is gone already: nothing left to tell it
        log.debug("closing a failed feed's socket: %r", exc)
