"""What mutual TLS costs: the same two nodes with and without it, on the mesh and on Zenoh.

Run: ``.venv/bin/python bench/tls.py`` (``--updates 3000 --sessions 40 --rounds 3``).

Two nodes in one process, linked on 127.0.0.1: ``a`` publishes its position, ``b``
hears it. For each transport, plain links (``insecure=True``, the baseline) and TLS
links (certificates of a throwaway CA) are measured in alternating rounds:

- CPU per delivered property update: ``a`` publishes ``--updates`` positions, paced at
  a thousand a second; the process's CPU time (every thread: Zenoh's too) over the
  updates ``b``'s observer saw;
- session setup: ``start_interaction`` on ``a`` until ``in_group`` of ``b``'s
  participant, ``--sessions`` times; the median.

Goals (issue 37): TLS costs at most 20 % more CPU per delivered update and at most
twice the session setup median. Each figure is the median of the rounds.
"""

from __future__ import annotations

import argparse
import asyncio
import statistics
import sys
import time
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent
# Run as a script, bench/ itself comes first on the path and its tuplespace.py would
# shadow the package of that name.
sys.path[:] = [p for p in sys.path if Path(p or ".").resolve() != HERE.parent]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench.report import markdown_table, publish  # noqa: E402
from objectplaces import Initiator, Participant, ParticipantRef, groups  # noqa: E402
from objectplaces.mesh import start_node  # noqa: E402
from objectplaces.network_node import NetworkNode  # noqa: E402
from objectplaces.security import TemporaryPki  # noqa: E402
from objectplaces.zenoh_node import start_zenoh_node  # noqa: E402

SECRET = b"bench-secret-of-plain-loopback-links"
PACE_S = 0.001
CPU_GOAL = 1.2
SETUP_GOAL = 2.0

Pair = tuple[NetworkNode, NetworkNode]
Starter = Callable[[TemporaryPki | None], Awaitable[Pair]]


class Joined(Initiator):
    """Sets ``joined`` at the first ``in_group``."""

    def __init__(self) -> None:
        self.joined = asyncio.Event()

    def in_group(self, participant: ParticipantRef) -> None:
        self.joined.set()


async def mesh_pair(pki: TemporaryPki | None) -> Pair:
    def credentials(node_id: str) -> dict[str, Any]:
        if pki is None:
            return {"insecure": True, "secret": SECRET}
        return {"tls": pki.identity(node_id)}

    a = await start_node("a", **credentials("a"))
    b = await start_node("b", join=[a.address], **credentials("b"))
    return a, b


async def zenoh_pair(pki: TemporaryPki | None) -> Pair:
    def credentials(node_id: str) -> dict[str, Any]:
        if pki is None:
            return {"insecure": True, "secret": SECRET, "listen": ["tcp/127.0.0.1:0"]}
        return {"tls": pki.identity(node_id), "listen": ["tls/127.0.0.1:0"]}

    a = await start_zenoh_node("a", **credentials("a"))
    b = await start_zenoh_node("b", connect=a.address.split(","), **credentials("b"))
    return a, b


async def measure(
    start: Starter, pki: TemporaryPki | None, updates: int, sessions: int
) -> dict[str, float]:
    """One round on one pair of nodes: CPU per delivered update, session setup median."""
    a, b = await start(pki)
    try:
        heard = 0
        enough = asyncio.Event()
        target = 1

        def on_property(node_id: str, name: str, _value: Any) -> None:
            nonlocal heard
            if node_id == "a":
                heard += 1
                if heard >= target:
                    enough.set()

        b.register_node_property_observer(on_property, names=("position",))
        b.set_participant_factory("p", Participant)
        b.update_node_property("position", (1.0, 0.0))
        a.update_node_property("position", (0.0, 0.0))
        async with asyncio.timeout(60):
            await enough.wait()
        heard, target = 0, int(updates * 0.99)  # the newest wins: a coalesced one is fine
        enough.clear()
        cpu0 = time.process_time()
        for i in range(updates):
            a.update_node_property("position", (float(i % 100) / 100, 0.0))
            await asyncio.sleep(PACE_S)
        async with asyncio.timeout(60):
            await enough.wait()
        cpu = time.process_time() - cpu0
        setups = []
        for _ in range(sessions):
            role = Joined()
            t0 = time.perf_counter()
            session = a.start_interaction(role, groups.within(5.0), "p")
            async with asyncio.timeout(30):
                await role.joined.wait()
            setups.append(time.perf_counter() - t0)
            a.stop_interaction(session)
            async with asyncio.timeout(30):
                while b.participations():  # noqa: ASYNC110 (no event for a role's end)
                    await asyncio.sleep(0.002)
        return {
            "cpu_us_per_update": cpu / max(heard, 1) * 1e6,
            "delivered": heard,
            "setup_ms_p50": statistics.median(setups) * 1e3,
        }
    finally:
        await b.close()
        await a.close()


async def run(updates: int, sessions: int, rounds: int) -> list[list[object]]:
    rows: list[list[object]] = []
    with TemporaryPki(fleet="bench") as pki:
        for name, start in (("mesh", mesh_pair), ("zenoh", zenoh_pair)):
            plain: list[dict[str, float]] = []
            tls: list[dict[str, float]] = []
            for r in range(rounds):
                for label, results, credentials in (("plain", plain, None), ("tls", tls, pki)):
                    figures = await measure(start, credentials, updates, sessions)
                    results.append(figures)
                    print(f"{name} round {r + 1} {label}: {figures}", file=sys.stderr)

            def median(results: list[dict[str, float]], key: str) -> float:
                return statistics.median(f[key] for f in results)

            cpu_plain, cpu_tls = (
                median(plain, "cpu_us_per_update"),
                median(tls, "cpu_us_per_update"),
            )
            set_plain, set_tls = median(plain, "setup_ms_p50"), median(tls, "setup_ms_p50")
            cpu_ratio, setup_ratio = cpu_tls / cpu_plain, set_tls / set_plain
            rows.append(
                [
                    name,
                    f"{cpu_plain:.1f}",
                    f"{cpu_tls:.1f}",
                    f"{cpu_ratio:.2f}x ({'met' if cpu_ratio <= CPU_GOAL else 'missed'})",
                    f"{set_plain:.2f}",
                    f"{set_tls:.2f}",
                    f"{setup_ratio:.2f}x ({'met' if setup_ratio <= SETUP_GOAL else 'missed'})",
                ]
            )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--updates", type=int, default=3000)
    parser.add_argument("--sessions", type=int, default=40)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    rows = asyncio.run(run(args.updates, args.sessions, args.rounds))
    table = markdown_table(
        [
            "transport",
            "CPU per update, plain (µs)",
            "with TLS (µs)",
            f"ratio (goal <= {CPU_GOAL}x)",
            "session setup p50, plain (ms)",
            "with TLS (ms)",
            f"ratio (goal <= {SETUP_GOAL:g}x)",
        ],
        rows,
    )
    body = (
        f"Two nodes in one process on 127.0.0.1, plain links against mutual TLS (TLS 1.3,\n"
        f"ECDSA P-256), measured in alternating rounds; each figure the median of "
        f"{args.rounds} rounds of {args.updates} position updates (a thousand a second) and "
        f"{args.sessions} session setups. CPU is the process's, every thread included.\n\n"
        f"{table}\n"
    )
    command = ".venv/bin/python bench/tls.py"
    publish("tls", "Mutual TLS: what it costs (bench/tls.py)", body, command)


if __name__ == "__main__":
    main()
