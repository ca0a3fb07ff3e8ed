"""A Zenoh router in this process, for nodes in client mode (no extra binary).

The router authenticates every link with the fleet's credentials, as nodes do
(``objectplaces.transport.zenoh_config``), forwards between its clients and the peers
connected to it, and lets through only the keys of its fleet (Zenoh's access control).
``objectplaces router`` runs one from the command line.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Sequence

import zenoh

from objectplaces.transport.zenoh_config import (
    CredentialsFile,
    ZenohOptions,
    derive_credentials,
    resolve_ports,
    zenoh_config,
)

__all__ = ["ZenohRouter", "start_router"]


class ZenohRouter:
    """A running router; ``await router.close()`` stops it."""

    def __init__(self, session: zenoh.Session, options: ZenohOptions, file: CredentialsFile):
        self._session = session
        self._file = file
        self.options = options

    @property
    def address(self) -> str:
        """The endpoints the router listens on (comma separated)."""
        return ",".join(self.options.listen)

    @property
    def endpoints(self) -> list[str]:
        """The endpoints the router listens on."""
        return list(self.options.listen)

    async def close(self) -> None:
        """Stop routing and remove the credentials file."""
        with contextlib.suppress(zenoh.ZError):
            await asyncio.to_thread(self._session.close)
        self._file.remove()

    async def __aenter__(self) -> ZenohRouter:
        return self

    async def __aexit__(self, *_exc: object) -> None:
        await self.close()


async def start_router(
    *,
    secret: bytes,
    listen: Sequence[str] = ("tcp/127.0.0.1:7447",),
    connect: Sequence[str] = (),
    fleet: str = "default",
    lease: float = 10.0,
) -> ZenohRouter:
    """Start a router listening on ``listen`` (port 0 picks a free port).

    Raises:
        LocalProtocolError: a bad argument.
        OSError: Zenoh could not open the router (an endpoint cannot be bound ...).
    """
    options = ZenohOptions(
        mode="router",
        listen=resolve_ports(listen),
        connect=tuple(connect),
        fleet=fleet,
        lease=lease,
    )
    credentials = derive_credentials(secret, fleet)
    file = CredentialsFile(credentials)
    try:
        session = await asyncio.to_thread(zenoh.open, zenoh_config(options, credentials, file.path))
    except zenoh.ZError as exc:
        file.remove()
        raise OSError(f"zenoh router: {exc}") from exc
    return ZenohRouter(session, options, file)
