"""Raw Zenoh sessions for the tests, as an intruder would open them: with the fleet's
credentials or wrong ones (plain links), with a certificate or none (TLS)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Sequence
from pathlib import Path

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


async def open_tls_session(
    connect: Sequence[str],
    *,
    ca: Path,
    cert: Path | None,
    key: Path | None,
    mode: Mode = "client",
    verify_name: bool = True,
) -> zenoh.Session:
    """A bare TLS session (no node, no access control of its own) that trusts ``ca`` and
    presents ``cert`` (None: no certificate): what anyone can configure by hand. A
    client fails to open unless a router takes its links; a peer opens, linked or not."""
    tls: dict[str, object] = {
        "root_ca_certificate": str(ca),
        "enable_mtls": cert is not None,
        "verify_name_on_connect": verify_name,
    }
    if cert is not None and key is not None:
        for side in ("listen", "connect"):
            tls[f"{side}_certificate"] = str(cert)
            tls[f"{side}_private_key"] = str(key)
    settings: dict[str, object] = {
        "mode": mode,
        "connect/endpoints": list(connect),
        "listen/endpoints": [],
        "scouting/multicast/enabled": False,
        "scouting/gossip/enabled": False,
        "transport/link/tls": tls,
    }
    config = zenoh.Config()
    for name, value in settings.items():
        config.insert_json5(name, json.dumps(value))
    return await asyncio.to_thread(zenoh.open, config)
