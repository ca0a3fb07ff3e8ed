"""Waiting in asyncio tests for something real processes and sockets do in their time."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable

__all__ = ["until"]


async def until(predicate: Callable[[], bool], within: float = 30.0) -> None:
    """Return once ``predicate()`` holds; fail the test if it does not within ``within`` s."""
    deadline = time.monotonic() + within
    while not predicate():
        assert time.monotonic() < deadline, f"not within {within}s"
        await asyncio.sleep(0.005)
