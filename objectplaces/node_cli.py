"""``objectplaces node``: run one ObjectPlaces node on the WebSocket mesh or on Zenoh.

``--transport zenoh`` puts the node on Zenoh (``--listen``/``--connect`` take Zenoh
endpoints such as ``tls/10.0.0.1:7447``; ``--mode client`` connects to a router).

Registered as a plugin of the ``objectplaces`` command (entry point group
``objectplaces.commands``, name ``node``). It joins with ``--pki D`` (mutual TLS with
its certificate ``D/ID.pem``) or, on loopback only, ``--insecure`` and a secret
(``--secret-file``); a credential that cannot be used exits with status 2, named.
SIGTERM and SIGINT make the node leave cleanly. The node publishes the properties it
is given and runs until ``--run-seconds`` pass or it is told to quit. Two small built-in
roles make a node observable from outside, for tests and demonstrations:

- ``--role collector`` starts a session (group ``--group``) and prints every
  ``in_group``, ``out_group`` and ``receive`` of its initiator;
- ``--role echo`` registers the participant role ``echo``: it greets its initiator, sends
  a tick every ``--tick`` seconds and echoes what it receives.

Output is one JSON object per line on stdout (``{"event": ..., "t": monotonic time}``).
The last is ``closed`` with its reason; should the node's mesh stop by itself, the
process says why there and exits with status 1.
With ``--control`` the node also reads JSON commands from stdin, one per line:
``{"cmd": "move", "x": 1, "y": 2}``, ``{"cmd": "set", "name": ..., "value": ...}``,
``{"cmd": "view"}``, ``{"cmd": "peers"}``, ``{"cmd": "stats"}``, ``{"cmd": "stop"}``,
``{"cmd": "start"}``, ``{"cmd": "quit"}``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import json
import logging
import signal
import sys
import time
from typing import TYPE_CHECKING, Any, TypeAlias

from objectplaces.activator import Session
from objectplaces.arguments import POSITIVE, group_argument, property_argument, whole
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.ids import InitiatorRef, ParticipantRef
from objectplaces.core.roles import Initiator, Participant
from objectplaces.mesh import MeshNode, MeshOptions, start_node
from objectplaces.security import (
    CredentialError,
    Credentials,
    add_credential_arguments,
    credentials_from_args,
)
from objectplaces.transport.options import MIN_FRAME

__all__ = [
    "Collector",
    "EchoVoter",
    "emit",
    "main",
    "register",
    "run_node",
]

_MAX_LINE = 1 << 16

if TYPE_CHECKING:  # the Zenoh transport is an extra: imported when asked for
    from objectplaces.zenoh_node import ZenohNode

AnyNode: TypeAlias = "MeshNode | ZenohNode"


def emit(event: str, **fields: Any) -> None:
    """Print one event as a JSON line on stdout."""
    record = {"event": event, "t": time.monotonic(), **fields}
    sys.stdout.write(json.dumps(record, default=repr) + "\n")
    sys.stdout.flush()


class Collector(Initiator):
    """An initiator that reports its group events and greets every new member."""

    def in_group(self, p: ParticipantRef) -> None:
        """Report the new member and greet it."""
        emit("in_group", peer=p.node_id, session=p.session_id)
        self.send(p, {"ping": p.node_id})

    def out_group(self, p: ParticipantRef) -> None:
        """Report the member that left."""
        emit("out_group", peer=p.node_id, session=p.session_id)

    def receive(self, p: ParticipantRef, message: Any) -> None:
        """Report a message from a member."""
        emit("receive", peer=p.node_id, message=message)


class EchoVoter(Participant):
    """A participant that greets its initiator, ticks, and echoes what it hears."""

    tick = 0.2

    def __init__(self) -> None:
        self._ticks = 0

    def in_group_of(self, initiator: InitiatorRef) -> None:
        """Greet the initiator and start ticking."""
        emit("in_group_of", initiator=initiator.node_id, session=initiator.session_id)
        self.send({"hello": self.node_id})
        self.call_later(self.tick, self._on_tick)

    def out_group_of(self, initiator: InitiatorRef) -> None:
        """Report the deactivation (the timers stop by themselves)."""
        emit("out_group_of", initiator=initiator.node_id, session=initiator.session_id)

    def receive(self, message: Any) -> None:
        """Echo a message back to the initiator."""
        self.send({"echo": message, "from": self.node_id})

    def _on_tick(self) -> None:
        self._ticks += 1
        self.send({"tick": self._ticks, "from": self.node_id})
        self.call_later(self.tick, self._on_tick)


def register(subcommands: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``node`` subcommand to the ``objectplaces`` command line."""
    parser = subcommands.add_parser(
        "node",
        help="run one node on the WebSocket mesh or on Zenoh",
        description="Run one ObjectPlaces node (JSON events on stdout).",
    )
    parser.add_argument("--id", required=True, help="node id, unique in the mesh")
    parser.add_argument(
        "--transport", choices=["websocket", "zenoh"], default="websocket", help="how nodes talk"
    )
    parser.add_argument(
        "--listen",
        help="host:port to listen on (zenoh: an endpoint, default tcp/127.0.0.1:0)",
    )
    parser.add_argument(
        "--connect",
        action="append",
        default=[],
        metavar="ENDPOINT",
        help="zenoh: a peer or router endpoint to connect to",
    )
    parser.add_argument("--mode", choices=["peer", "client"], default="peer", help="zenoh mode")
    parser.add_argument("--fleet", help="zenoh: the fleet's name (default: the certificate's)")
    parser.add_argument("--lease", type=POSITIVE, default=10.0, help="zenoh: link lease, s")
    parser.add_argument(
        "--join", action="append", default=[], metavar="HOST:PORT", help="a node to join through"
    )
    add_credential_arguments(parser)
    parser.add_argument(
        "--property",
        action="append",
        type=property_argument,
        default=[],
        metavar="NAME=JSON",
        help="a property to publish, e.g. position=[1,2]",
    )
    parser.add_argument("--interest-radius", type=POSITIVE, help="scoped dissemination radius, m")
    parser.add_argument("--property-interval", type=POSITIVE, default=1.0, help="heartbeat, s")
    parser.add_argument(
        "--beat-interval",
        type=POSITIVE,
        help="send a beat of a few bytes after this long without a publication, s "
        "(default: none, the property interval is the heartbeat)",
    )
    parser.add_argument("--failure-timeout", type=POSITIVE, help="failure timeout, s")
    parser.add_argument("--run-seconds", type=POSITIVE, default=3600.0, help="stop after this")
    parser.add_argument("--role", choices=["none", "collector", "echo"], default="none")
    parser.add_argument(
        "--group", type=group_argument, default="within:5", help="within:D or circles"
    )
    parser.add_argument("--tick", type=POSITIVE, default=0.2, help="echo role tick period, s")
    parser.add_argument("--control", action="store_true", help="read JSON commands on stdin")
    parser.add_argument("--flood-rate", type=POSITIVE, help="frames/s a peer may send")
    parser.add_argument("--flood-burst", type=POSITIVE, help="frames a peer may send at once")
    parser.add_argument("--max-frame", type=whole(at_least=MIN_FRAME), help="largest frame, bytes")
    parser.add_argument("--log-level", default="WARNING", help="logging level on stderr")
    parser.set_defaults(func=run_node)


def _options(args: argparse.Namespace) -> MeshOptions:
    overrides: dict[str, Any] = {}
    if args.flood_rate is not None:
        overrides["flood_rate"] = args.flood_rate
    if args.flood_burst is not None:
        overrides["flood_burst"] = args.flood_burst
    if args.max_frame is not None:
        overrides["max_frame"] = args.max_frame
    return MeshOptions(**overrides)


def run_node(args: argparse.Namespace) -> int:
    """Run the ``node`` subcommand.

    Returns:
        The exit status (0 when the node ran and left cleanly).
    """
    logging.basicConfig(
        level=args.log_level.upper(), stream=sys.stderr, format="%(levelname)s %(message)s"
    )
    try:
        credentials = credentials_from_args(args, args.id)
    except CredentialError as exc:
        print(f"objectplaces node: {exc}", file=sys.stderr)
        return 2
    EchoVoter.tick = args.tick
    try:
        return asyncio.run(_run(args, credentials))
    except (CredentialError, ImportError) as exc:  # ImportError: a missing extra, named
        print(f"objectplaces node: {exc}", file=sys.stderr)
        return 2
    except (LocalProtocolError, OSError) as exc:
        print(f"objectplaces node: {exc}", file=sys.stderr)
        return 1


class _Controller:
    """Carries out the commands read from stdin."""

    def __init__(self, node: AnyNode, args: argparse.Namespace, stop: asyncio.Event) -> None:
        self.node = node
        self.args = args
        self.stop = stop
        self.session: Session | None = None

    def start_session(self) -> None:
        if self.session is None:
            self.session = self.node.start_interaction(Collector(), self.args.group, "echo")
            emit("started", session=self.session.session_id)

    def handle(self, line: bytes) -> None:
        try:
            command = json.loads(line)
            if not isinstance(command, dict):
                raise TypeError("a command is a JSON object")
            self._do(command)
        except (ValueError, TypeError, KeyError, LocalProtocolError) as exc:
            emit("error", error=str(exc))

    def _do(self, command: dict[str, Any]) -> None:
        node = self.node
        match command.get("cmd"):
            case "move":
                node.update_node_property("position", (float(command["x"]), float(command["y"])))
                emit("moved", position=[command["x"], command["y"]])
            case "set":
                name, value = command["name"], command["value"]
                node.update_node_property(name, tuple(value) if name == "position" else value)
                emit("set", name=name)
            case "view":
                emit("view", view={n: dict(p) for n, p in sorted(node.view().items())})
            case "peers":
                emit("peers", peers=node.peers())
            case "stats":
                stats = {p: dataclasses.asdict(s) for p, s in node.peer_stats().items()}
                emit("stats", peers=stats, counters=node.transport_counters())
            case "start":
                self.start_session()
            case "stop":
                if self.session is not None:
                    node.stop_interaction(self.session)
                    self.session = None
                    emit("stopped")
            case "quit":
                self.stop.set()
            case other:
                emit("error", error=f"unknown command {other!r}")


async def _read_commands(controller: _Controller) -> None:
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader(limit=_MAX_LINE)
    try:
        await loop.connect_read_pipe(lambda: asyncio.StreamReaderProtocol(reader), sys.stdin)
    except (OSError, ValueError) as exc:
        emit("error", error=f"cannot read commands: {exc}")
        return
    while True:
        try:
            line = await reader.readline()
        except ValueError:
            emit("error", error="command line too long")
            continue
        if not line:
            return
        if line.strip():
            controller.handle(line)


async def _watch_peers(node: AnyNode) -> None:
    seen: list[str] | None = None
    while True:
        peers = node.peers()
        if peers != seen:
            seen = peers
            emit("peers", peers=peers)
        await node.links_changed()


async def _start(args: argparse.Namespace, credentials: Credentials) -> AnyNode:
    if args.transport == "zenoh":
        protocol = "tcp" if credentials.insecure else "tls"
        return await start_node(
            args.id,
            transport="zenoh",
            tls=credentials.tls,
            insecure=credentials.insecure,
            secret=credentials.secret,
            listen=[args.listen or f"{protocol}/127.0.0.1:0"],
            connect=args.connect,
            mode=args.mode,
            fleet=args.fleet,
            lease=args.lease,
            max_frame=args.max_frame,
            interest_radius=args.interest_radius,
            property_interval=args.property_interval,
            beat_interval=args.beat_interval,
            failure_timeout=args.failure_timeout,
        )
    return await start_node(
        args.id,
        tls=credentials.tls,
        insecure=credentials.insecure,
        secret=credentials.secret,
        listen=args.listen or "127.0.0.1:0",
        join=args.join,
        options=_options(args),
        interest_radius=args.interest_radius,
        property_interval=args.property_interval,
        beat_interval=args.beat_interval,
        failure_timeout=args.failure_timeout,
    )


async def _run(args: argparse.Namespace, credentials: Credentials) -> int:
    node = await _start(args, credentials)
    stop = asyncio.Event()
    controller = _Controller(node, args, stop)
    stopped: str | None = None
    loop = asyncio.get_running_loop()
    signals = (signal.SIGTERM, signal.SIGINT)
    for signum in signals:  # leave cleanly: the node's credentials files go with it
        loop.add_signal_handler(signum, stop.set)
    try:
        for name, value in args.property:
            node.update_node_property(name, value)
        if args.role == "echo":
            node.set_participant_factory("echo", EchoVoter)
        node.register_node_departure_observer(lambda peer, _: emit("departed", peer=peer))
        emit("ready", id=node.node_id, address=node.address)
        if args.role == "collector":
            controller.start_session()
        async with asyncio.TaskGroup() as tg:
            tasks = [tg.create_task(_watch_peers(node))]
            if args.control:
                tasks.append(tg.create_task(_read_commands(controller)))
            waits = [tg.create_task(stop.wait()), tg.create_task(node.wait_closed())]
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(args.run_seconds):
                    await asyncio.wait(waits, return_when=asyncio.FIRST_COMPLETED)
            for task in tasks + waits:
                task.cancel()
        # The node closed by itself (its mesh stopped): the process says why, and fails.
        stopped = node.close_reason
    finally:
        for signum in signals:
            loop.remove_signal_handler(signum)
        await node.close()
        emit("closed", reason=stopped or "left the mesh")
    return 1 if stopped else 0


def main(argv: list[str] | None = None) -> int:
    """Run ``objectplaces node`` without loading the other subcommands (faster start).

    Args:
        argv: the ``node`` subcommand's arguments; ``sys.argv[1:]`` when None.
    """
    parser = argparse.ArgumentParser(prog="objectplaces")
    register(parser.add_subparsers())
    args = parser.parse_args(["node", *(sys.argv[1:] if argv is None else argv)])
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
