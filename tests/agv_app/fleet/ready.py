"""Waiting for a fleet of AGV processes to be heard, for the tests that start one."""

from __future__ import annotations

import asyncio

import pytest

from agv_app.fleet import MeshFleet

__all__ = ["heard_by_all"]


async def heard_by_all(fleet: MeshFleet, within: float = 40.0) -> None:
    """Wait until the observer hears every AGV process and has its display; fail naming
    who is still unheard, with the processes' output."""
    try:
        async with asyncio.timeout(within):
            await fleet.wait_ready()
    except TimeoutError:
        pytest.fail(f"unheard: {fleet.missing()}; logs: {fleet.child_logs()}")
