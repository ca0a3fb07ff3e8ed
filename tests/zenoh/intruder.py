"""A raw Zenoh session for the tests: with the fleet's credentials, or with wrong ones."""

from __future__ import annotations

import asyncio
from collections.abc import Sequence

import zenoh

from objectplaces.transport.zenoh_config import (
    CredentialsFile,
    Mode,
    ZenohOptions,
    ZenohSecurity,
    derive_credentials,
    zenoh_config,
)


async def open_fleet_session(
    secret: bytes, connect: Sequence[str], *, fleet: str = "default", mode: Mode = "client"
) -> zenoh.Session:
    """A bare session (no node) holding credentials derived from ``secret``: a client
    (which fails to open unless a router takes its credentials) or a peer (which opens,
    linked or not)."""
    options = ZenohOptions(mode=mode, connect=tuple(connect), fleet=fleet, listen=())
    credentials = derive_credentials(secret, fleet)
    file = CredentialsFile(credentials)
    try:
        config = zenoh_config(options, ZenohSecurity(usrpwd=(credentials, file.path)))
        return await asyncio.to_thread(zenoh.open, config)
    finally:
        file.remove()
