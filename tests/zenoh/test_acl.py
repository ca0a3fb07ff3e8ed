"""The fleet's access control, checked against the keys nodes really use (no session):
every key a member puts, declares or asks on is allowed to it and to nobody else, the
per-node keys it may read are its own, and the revoked get no rule."""

from __future__ import annotations

import json
from typing import Any

import pytest
import zenoh

from objectplaces.security.pki import Issued
from objectplaces.transport.zenoh_acl import (
    ALL_MESSAGES,
    Roster,
    fleet_access_control,
    roster_of,
    secret_access_control,
)
from objectplaces.transport.zenoh_keys import FleetKeys

ROSTER = Roster(members=("a", "b"), routers=("r1",))


def allowed(acl: dict[str, Any], node: str, flow: str, message: str, key: str) -> bool:
    """Whether ``acl`` lets ``message`` on ``key`` pass ``flow`` on ``node``'s link, as
    Zenoh decides with ``default_permission: deny``: some rule of a policy whose subject
    names ``node`` allows it, its key expression including the message's."""
    assert acl["default_permission"] == "deny"
    subjects = {s["id"] for s in acl["subjects"] if node in s.get("cert_common_names", [])}
    rules = {r["id"]: r for r in acl["rules"]}
    for policy in acl["policies"]:
        if not subjects.intersection(policy["subjects"]):
            continue
        for rule in map(rules.__getitem__, policy["rules"]):
            if (
                flow in rule["flows"]
                and message in rule["messages"]
                and any(zenoh.KeyExpr(k).includes(zenoh.KeyExpr(key)) for k in rule["key_exprs"])
            ):
                return True
    return False


def own_keys(node: str) -> list[tuple[str, str]]:
    """What ``node`` sends into the fleet: (message, key), from ``FleetKeys`` itself."""
    keys = FleetKeys("f", node)
    return [
        ("put", keys.props((1, -2))),
        ("put", keys.props((0, 0), left=True)),
        ("put", keys.broadcast()),
        ("put", keys.to("b" if node != "b" else "a")),
        ("liveliness_token", keys.alive(1_234_567)),
        ("declare_queryable", keys.who((3, 4))),
        ("declare_queryable", keys.who(None)),
        ("declare_subscriber", keys.inbox()),
    ]


def shared_keys() -> list[tuple[str, str]]:
    """What every member asks and hears alike."""
    keys = FleetKeys("f", "a")
    return [
        ("declare_subscriber", keys.cell_subscription((1, 2))),
        ("declare_subscriber", keys.row_subscription(-3)),
        ("declare_subscriber", keys.all_props()),
        ("declare_subscriber", keys.broadcasts()),
        ("declare_liveliness_subscriber", keys.alive_all()),
        ("liveliness_query", keys.alive_all()),
        ("query", keys.who_in((1, 2))),
        ("query", keys.who_in(None)),
        ("query", keys.who_is("b")),
        ("query", keys.who_all()),
    ]


@pytest.mark.parametrize("node", ["a", "b"])
def test_a_member_may_send_on_its_own_keys_and_nobody_else_may(node: str) -> None:
    acl = fleet_access_control("f", ROSTER)
    other = "b" if node == "a" else "a"
    for message, key in own_keys(node):
        assert allowed(acl, node, "ingress", message, key), (message, key)
        assert not allowed(acl, other, "ingress", message, key), (message, key)
        assert not allowed(acl, "c", "ingress", message, key), (message, key)


def test_every_member_may_hear_the_cells_and_ask_alike() -> None:
    acl = fleet_access_control("f", ROSTER)
    for message, key in shared_keys():
        assert allowed(acl, "a", "ingress", message, key), (message, key)
        assert allowed(acl, "b", "ingress", message, key), (message, key)
        assert not allowed(acl, "c", "ingress", message, key), (message, key)


def test_of_the_per_node_keys_a_member_reads_only_its_own_inbox() -> None:
    acl = fleet_access_control("f", ROSTER)
    a, b = FleetKeys("f", "a"), FleetKeys("f", "b")
    assert allowed(acl, "b", "egress", "put", a.to("b"))
    assert not allowed(acl, "b", "egress", "put", b.to("a"))
    assert not allowed(acl, "b", "ingress", "declare_subscriber", a.inbox())
    for pattern in ("objectplaces/f/to/*/*", "objectplaces/f/to/**", "objectplaces/f/**"):
        assert not allowed(acl, "b", "ingress", "declare_subscriber", pattern)
    # Property cells and broadcasts stay readable by every member.
    assert allowed(acl, "b", "egress", "put", a.props((5, 5)))
    assert allowed(acl, "b", "egress", "put", a.props((5, 5), left=True))
    assert allowed(acl, "b", "egress", "put", a.broadcast())
    assert allowed(acl, "b", "egress", "liveliness_token", a.alive(7))


def test_nothing_outside_the_fleet_and_no_delete_passes() -> None:
    acl = fleet_access_control("f", ROSTER)
    for flow in ("ingress", "egress"):
        assert not allowed(acl, "a", flow, "put", "objectplaces/g/all/a")
        assert not allowed(acl, "a", flow, "put", "@/admin")
        assert not allowed(acl, "a", flow, "delete", FleetKeys("f", "a").broadcast())


def test_routers_pass_the_whole_fleet() -> None:
    acl = fleet_access_control("f", ROSTER)
    for flow in ("ingress", "egress"):
        for message in ALL_MESSAGES:
            assert allowed(acl, "r1", flow, message, "objectplaces/f/to/a/b")
        assert not allowed(acl, "r1", flow, "put", "objectplaces/g/to/a/b")


def test_an_empty_roster_lets_nothing_through() -> None:
    acl = fleet_access_control("f", Roster())
    assert acl["rules"] == acl["subjects"] == acl["policies"] == []


@pytest.mark.parametrize(
    "acl",
    [
        fleet_access_control("f", ROSTER),
        fleet_access_control("f", Roster()),
        secret_access_control("f", "op-1"),
    ],
    ids=["roster", "empty", "secret"],
)
def test_the_rules_are_an_access_control_zenoh_opens_with(acl: dict[str, Any]) -> None:
    config = zenoh.Config()
    for key, value in {
        "mode": "peer",
        "listen/endpoints": [],
        "scouting/multicast/enabled": False,
        "access_control": acl,
    }.items():
        config.insert_json5(key, json.dumps(value))
    zenoh.open(config).close()  # type: ignore[no-untyped-call]


def test_the_roster_holds_the_current_certificates_by_role() -> None:
    issued = [
        Issued("a", "agv", 1, "2030"),
        Issued("b", "control", 2, "2030"),
        Issued("c", "agv", 3, "2030", revoked="2026"),
        Issued("c", "agv", 4, "2030"),  # issued again under the same id
        Issued("d", "node", 5, "2030"),  # on the CRL, not yet marked in the index
        Issued("m", "master", 6, "2030"),
        Issued("r1", "router", 7, "2030"),
        Issued("x", "agv", 8, "2030", revoked="2026"),
    ]
    roster = roster_of(issued, revoked_serials={3, 5, 8})
    assert roster == Roster(members=("a", "b", "c"), routers=("r1",), revoked=("d", "x"))
