"""``objectplaces router``: a Zenoh router for nodes in client mode, in this process.

```
objectplaces pki issue --dir fleet-pki router-1 --role router --address 10.0.0.1
objectplaces router --id router-1 --pki fleet-pki --listen tls/10.0.0.1:7447
objectplaces node --transport zenoh --mode client --connect tls/10.0.0.1:7447 --pki ...
```

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``router``). It prints one JSON line ``ready`` with its
endpoints, runs until ``--run-seconds`` pass or it gets SIGTERM or SIGINT, then closes
(removing any credentials file it wrote) and prints ``closed``. A credential that
cannot be used is named on stderr, with exit status 2.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal
import sys
from collections.abc import Iterator

from objectplaces.arguments import POSITIVE
from objectplaces.core.errors import LocalProtocolError
from objectplaces.node_cli import emit
from objectplaces.security.errors import CredentialError
from objectplaces.security.options import (
    Credentials,
    add_credential_arguments,
    credentials_from_args,
)
from objectplaces.zenoh_router import start_router

__all__ = ["main", "register", "run_router"]


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``router`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "router",
        help="run a Zenoh router for client-mode nodes",
        description="Run a Zenoh router: mutual TLS, each member only its own keys.",
    )
    parser.add_argument(
        "--id", default="router", help="the router's id: its certificate's name (default router)"
    )
    parser.add_argument(
        "--listen",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="endpoint to listen on (default tls/127.0.0.1:7447, tcp/ with --insecure; "
        "port 0 picks one)",
    )
    parser.add_argument(
        "--connect", action="append", default=[], metavar="ENDPOINT", help="another router"
    )
    parser.add_argument("--fleet", help="the fleet's name (default: the certificate's)")
    parser.add_argument("--lease", type=POSITIVE, default=10.0, help="link lease, s")
    parser.add_argument("--run-seconds", type=POSITIVE, default=3600.0, help="stop after this")
    add_credential_arguments(parser)
    parser.set_defaults(func=run_router)


def run_router(args: argparse.Namespace) -> int:
    """Run the ``router`` subcommand; returns the exit status."""
    try:
        credentials = credentials_from_args(args, args.id)
        asyncio.run(_run(args, credentials))
    except CredentialError as exc:
        print(f"objectplaces router: {exc}", file=sys.stderr)
        return 2
    except (LocalProtocolError, OSError) as exc:
        print(f"objectplaces router: {exc}", file=sys.stderr)
        return 1
    return 0


async def _run(args: argparse.Namespace, credentials: Credentials) -> None:
    protocol = "tcp" if credentials.insecure else "tls"
    with _signals() as signalled:
        router = await start_router(
            listen=args.listen or [f"{protocol}/127.0.0.1:7447"],
            connect=args.connect,
            fleet=args.fleet,
            lease=args.lease,
            tls=credentials.tls,
            insecure=credentials.insecure,
            secret=credentials.secret,
        )
        reason = "stopped"
        try:
            emit("ready", address=router.address, endpoints=router.endpoints)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(args.run_seconds):
                    reason = await signalled
        finally:
            await router.close()
            emit("closed", reason=reason)


@contextlib.contextmanager
def _signals() -> Iterator[asyncio.Future[str]]:
    """A future that SIGTERM or SIGINT sets to the signal's name, while in the block:
    either signal then ends the wait instead of the process, so that the router
    closes and its credentials file goes."""
    loop = asyncio.get_running_loop()
    signalled: asyncio.Future[str] = loop.create_future()
    signals = (signal.SIGTERM, signal.SIGINT)

    def on_signal(signum: signal.Signals) -> None:
        if not signalled.done():
            signalled.set_result(signum.name)

    for signum in signals:
        loop.add_signal_handler(signum, on_signal, signum)
    try:
        yield signalled
    finally:
        for signum in signals:
            loop.remove_signal_handler(signum)
        signalled.cancel()


def main(argv: list[str] | None = None) -> int:
    """Run ``objectplaces router`` without loading the other subcommands."""
    parser = argparse.ArgumentParser(prog="objectplaces")
    register(parser.add_subparsers())
    args = parser.parse_args(["router", *(sys.argv[1:] if argv is None else argv)])
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
