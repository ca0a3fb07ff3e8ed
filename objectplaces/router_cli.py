"""``objectplaces router``: a Zenoh router for nodes in client mode, in this process.

```
objectplaces router --listen tcp/127.0.0.1:7447 --secret-file fleet.secret
objectplaces node --transport zenoh --mode client --connect tcp/127.0.0.1:7447 ...
```

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``router``). It prints one JSON line ``ready`` with its
endpoints, runs until ``--run-seconds`` pass or it is interrupted, then ``closed``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import sys

from objectplaces.arguments import POSITIVE
from objectplaces.core.errors import LocalProtocolError
from objectplaces.node_cli import emit
from objectplaces.security import CredentialError, add_credential_arguments, credentials_from_args
from objectplaces.zenoh_router import start_router

__all__ = ["main", "register", "run_router"]


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``router`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "router",
        help="run a Zenoh router for client-mode nodes",
        description="Run a Zenoh router that authenticates links with the fleet secret.",
    )
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to listen on (default tcp/127.0.0.1:7447; port 0 picks one)",
    )
    parser.add_argument(
        "--connect", action="append", default=[], metavar="ENDPOINT", help="another router"
    )
    parser.add_argument("--id", default="router", help="the router's id (its certificate's)")
    add_credential_arguments(parser)
    parser.add_argument("--fleet", default="default", help="the fleet's name")
    parser.add_argument("--lease", type=POSITIVE, default=10.0, help="link lease, s")
    parser.add_argument("--run-seconds", type=POSITIVE, default=3600.0, help="stop after this")
    parser.set_defaults(func=run_router)


def run_router(args: argparse.Namespace) -> int:
    """Run the ``router`` subcommand; returns the exit status."""
    try:
        secret = credentials_from_args(args, args.id).secret or b""
    except CredentialError as exc:
        print(f"objectplaces router: {exc}", file=sys.stderr)
        return 2
    try:
        asyncio.run(_run(args, secret))
    except (LocalProtocolError, OSError) as exc:
        print(f"objectplaces router: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        pass
    return 0


async def _run(args: argparse.Namespace, secret: bytes) -> None:
    router = await start_router(
        secret=secret,
        listen=args.listen or ["tcp/127.0.0.1:7447"],
        connect=args.connect,
        fleet=args.fleet,
        lease=args.lease,
    )
    try:
        emit("ready", address=router.address, endpoints=router.endpoints)
        with contextlib.suppress(TimeoutError):
            await asyncio.sleep(args.run_seconds)
    finally:
        await router.close()
        emit("closed", reason="stopped")


def main(argv: list[str] | None = None) -> int:
    """Run ``objectplaces router`` without loading the other subcommands."""
    parser = argparse.ArgumentParser(prog="objectplaces")
    register(parser.add_subparsers())
    args = parser.parse_args(["router", *(sys.argv[1:] if argv is None else argv)])
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
