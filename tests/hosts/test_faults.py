"""A fleet across hosts survives each fault once: safe throughout, and it recovers.

Three vehicles, two routers and the control process, each on a host (network
namespace) of its own, run by the project's commands over mutual TLS. Each fault comes
once: a vehicle's link goes down (Wi-Fi roaming), a vehicle loses packets and has its
bandwidth capped, a router is killed (its clients move to the other) and started again,
the control process is killed and started again; then the fleet is heard whole and
drives on. Afterwards the vehicles' own traces
are merged: no collision, no lock overlap, not a centimetre driven outside a vehicle's
locked floor. The bounds are generous (a loaded machine): how fast it recovers is the
bench's figure (bench/netfaults.py), not this test's.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.hosts.harness import FleetOnHosts

pytestmark = pytest.mark.processes


def _moving(fleet: FleetOnHosts) -> bool:
    return any(v.get("status") == "driving" for v in (fleet.api("/api/vehicles") or []))


def test_a_fleet_across_hosts_survives_each_fault_once(tmp_path: Path) -> None:
    with FleetOnHosts(vehicles=3, routers=2, workdir=tmp_path, load=0.9) as fleet:
        fleet.start(within=180)
        fleet.until(lambda: _moving(fleet), 120, "a vehicle driving")

        fleet.outage("agv-01", 2.0)
        fleet.net.loss(fleet.procs["agv-02"].host, 5)
        fleet.net.cap(fleet.procs["agv-02"].host, 256)

        fleet.kill("r1")  # every client moves to r2
        fleet.until(lambda: len(fleet.heard()) == 3, 120, "every vehicle heard through r2")
        fleet.restart("r1")

        ordered = [fleet.order(fleet.picks[i % len(fleet.picks)]) for i in range(3)]
        fleet.kill("control")  # with orders open: none may be lost, none done twice
        fleet.restart("control")
        fleet.until(lambda: len(fleet.heard()) == 3, 180, "every vehicle heard after control")
        fleet.until(lambda: set(ordered) <= fleet.orders().keys(), 60, "every order back")
        fleet.until(lambda: _moving(fleet), 180, "a vehicle driving after every fault")
        report = fleet.stop()
        delivered = fleet.deliveries()
    assert set(ordered) <= delivered.keys(), "no order lost"
    assert max(delivered.values(), default=0) <= 1, "none done twice"
    assert report.vehicles == 3
    assert report.safe, report.details[:20]
    assert report.collisions == report.lock_overlaps == 0
    assert sum(report.outside_m.values()) == 0.0
