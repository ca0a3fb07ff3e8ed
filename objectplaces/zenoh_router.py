"""A Zenoh router in this process, for nodes in client mode (no extra binary).

```python
router = await start_router(tls=Identity.from_pki("fleet-pki", "router-1"),
                            listen=["tls/10.0.0.1:7447"])
```

With its certified identity (role ``router``, issued with the addresses it listens on)
every link is mutual TLS, and the router gives each member only its own keys by the
name on its certificate (``objectplaces.transport.zenoh_acl``): a member puts only on
its keys and of the per-node keys reads only its own inbox; other routers linked to it
get the whole fleet. The router looks at the fleet's ``members.json`` and revocation
list every ``ROSTER_CHECK`` seconds; when who may do what changes (a member issued or
revoked) it opens its session anew under the new rules. That closes every link: the
revoked member's for good, the others' until they link again (within a second or two,
by themselves). Plain ``tcp/`` links (``insecure=True``) are for loopback only, each
proving the fleet secret. ``objectplaces router`` runs one from the command line.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Sequence

from objectplaces.security.identity import Identity
from objectplaces.security.links import link_security
from objectplaces.transport.zenoh_acl import fleet_access_control, secret_access_control
from objectplaces.transport.zenoh_config import (
    Credentials,
    CredentialsFile,
    ZenohOptions,
    ZenohSecurity,
    check_protocol,
    derive_credentials,
    endpoint_host,
    fleet_of,
    resolve_ports,
    zenoh_config,
)
from objectplaces.transport.zenoh_lib import zenoh
from objectplaces.transport.zenoh_roster import ROSTER_CHECK, RosterWatch

__all__ = ["ZenohRouter", "start_router"]

log = logging.getLogger("objectplaces.zenoh")


class ZenohRouter:
    """A running router; ``await router.close()`` stops it.

    Made by ``start_router``. ``counters`` holds ``reopened`` (sessions opened anew
    for a new roster) and ``reopen_failed``.
    """

    def __init__(
        self,
        options: ZenohOptions,
        *,
        tls: Identity | None,
        credentials: Credentials | None,
    ) -> None:
        self.options = options
        self.counters: dict[str, int] = {}
        self._tls = tls
        self._credentials = credentials
        self._roster = RosterWatch(tls) if tls is not None else None
        self._file: CredentialsFile | None = None
        self._session: zenoh.Session | None = None
        self._watcher: asyncio.Task[None] | None = None
        self._reopening = False
        self._closed = False

    @property
    def address(self) -> str:
        """The endpoints the router listens on (comma separated)."""
        return ",".join(self.options.listen)

    @property
    def endpoints(self) -> list[str]:
        """The endpoints the router listens on."""
        return list(self.options.listen)

    def _security(self) -> ZenohSecurity:
        usrpwd = None
        if self._credentials is not None:
            assert self._file is not None
            usrpwd = (self._credentials, self._file.path)
        if self._roster is not None:
            acl = fleet_access_control(self.options.fleet, self._roster.roster)
        else:
            assert self._credentials is not None
            acl = secret_access_control(self.options.fleet, self._credentials.user)
        return ZenohSecurity(tls=self._tls, usrpwd=usrpwd, access_control=acl)

    async def _open_session(self) -> zenoh.Session:
        config = zenoh_config(self.options, self._security())
        try:
            return await asyncio.to_thread(zenoh.open, config)
        except zenoh.ZError as exc:
            raise OSError(f"zenoh router: {exc}") from exc

    async def open(self) -> None:
        """Open the session and start watching the roster.

        Raises:
            OSError: Zenoh could not open the router (an endpoint cannot be bound ...).
        """
        if self._credentials is not None:
            self._file = CredentialsFile(self._credentials)
        try:
            self._session = await self._open_session()
        except OSError:
            if self._file is not None:
                self._file.remove()
            raise
        if self._roster is not None:
            self._watcher = asyncio.get_running_loop().create_task(self._watch_roster())

    async def _watch_roster(self) -> None:
        """Open the session anew whenever the roster changes, until it is done."""
        assert self._roster is not None
        stale = False
        while not self._closed:
            await asyncio.sleep(ROSTER_CHECK)
            if self._roster.poll() is not None:
                log.warning("router: the fleet's roster changed: opening the session anew")
                stale = True
            if stale and not self._closed:
                self._reopening = True
                try:
                    stale = not await self._reopen()
                finally:
                    self._reopening = False

    async def _reopen(self) -> bool:
        old, self._session = self._session, None
        if old is not None:
            await _close_quietly(old)
        try:
            self._session = await self._open_session()
        except OSError as exc:
            log.error("router: opening the session anew: %s (trying again)", exc)
            self._count("reopen_failed")
            return False
        self._count("reopened")
        return True

    def _count(self, name: str) -> None:
        self.counters[name] = self.counters.get(name, 0) + 1

    async def close(self) -> None:
        """Stop routing and remove the credentials file (again is fine)."""
        if self._closed:
            return
        self._closed = True
        watcher = self._watcher
        if watcher is not None:
            if not self._reopening:  # a session being opened is let finish, then closed
                watcher.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await watcher
        session, self._session = self._session, None
        if session is not None:
            await _close_quietly(session)
        if self._file is not None:
            self._file.remove()

    async def __aenter__(self) -> ZenohRouter:
        return self

    async def __aexit__(self, *_exc: object) -> None:
        await self.close()


async def _close_quietly(session: zenoh.Session) -> None:
    with contextlib.suppress(zenoh.ZError):
        await asyncio.to_thread(session.close)


async def start_router(
    *,
    tls: Identity | None = None,
    insecure: bool = False,
    secret: bytes | None = None,
    listen: Sequence[str] | None = None,
    connect: Sequence[str] = (),
    fleet: str | None = None,
    lease: float = 10.0,
) -> ZenohRouter:
    """Start a router listening on ``listen`` (port 0 picks a free port).

    Args:
        tls: the router's certified identity (role ``router``; its certificate names the
            addresses it listens on, so that clients can check they reached it). Its
            CA's folder holds ``members.json`` and the revocation list, re-read on
            change.
        insecure: plain ``tcp/`` links instead, proven by ``secret``; loopback only.
        secret: with ``insecure``, the fleet secret (32 bytes or more); with ``tls``, a
            second factor every link proves.
        listen: endpoints to listen on; by default ``tls/127.0.0.1:7447`` (``tcp/``
            when insecure).
        connect: other routers to link to.
        fleet: the fleet's name; by default the certificate's (``default`` when insecure).
        lease: a silent link closes after this long, s.

    Raises:
        LocalProtocolError: a bad argument; neither ``tls`` nor ``insecure``; a plain
            link off loopback; an endpoint of the other protocol.
        CredentialError: the identity is not a router's, its PKI folder holds no
            ``members.json``, or the secret is too short.
        OSError: Zenoh could not open the router (an endpoint cannot be bound ...).
    """
    protocol = "tcp" if tls is None else "tls"
    listen = tuple(listen) if listen is not None else (f"{protocol}/127.0.0.1:7447",)
    ZenohOptions(mode="router", listen=listen, connect=tuple(connect))  # checks them
    hosts = [endpoint_host(e) for e in (*listen, *connect)]
    name = tls.node_id if tls is not None else "router"
    link_security(name, tls=tls, secret=secret, insecure=insecure, hosts=hosts, roles=("router",))
    check_protocol((*listen, *connect), protocol)
    options = ZenohOptions(
        mode="router",
        listen=resolve_ports(listen),
        connect=tuple(connect),
        fleet=fleet_of(tls, fleet),
        lease=lease,
    )
    credentials = derive_credentials(secret, options.fleet) if secret is not None else None
    router = ZenohRouter(options, tls=tls, credentials=credentials)
    await router.open()
    return router
