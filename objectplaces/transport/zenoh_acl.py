"""Zenoh access control for a fleet: each member its own keys, by certificate name (sans-I/O).

A router (and, in peer mode, every peer) applies Zenoh's access control to each link
by the common name of the certificate its peer proved, which is that member's node id.
With ``default_permission: deny``, a message passes only if a rule names it. For each
member ``X`` (``e``: ``X`` escaped, ``p``: ``objectplaces/<fleet>``; the keys are those
of ``zenoh_keys``):

========================  =============================================  =====================
flow and message          keys                                           why
========================  =============================================  =====================
in: put                   ``p/props/*/e``, ``p/props/*/e/left``,          what X publishes and
                          ``p/all/e``, ``p/to/*/e``                       sends: its own keys
in: declare_subscriber    ``p/props/**``, ``p/all/*``, ``p/to/e/*``       cells, broadcasts,
                                                                         its own inbox
in: liveliness_token      ``p/alive/e/*/*``                              its own token
in: declare_queryable     ``p/who/*/e``                                  its own queryables
in: query                 ``p/who/**``                                   asking late
in: liveliness sub/query  ``p/alive/**``                                 who is alive
out: put                  ``p/props/**``, ``p/all/*``, ``p/to/e/*``       what X may read
out: query                ``p/who/**``                                   asks for X's answer
out: declarations         ``p/alive/**`` (tokens, liveliness), ``p/**``  what routes need
                          (subscribers, queryables)                      (no data)
========================  =============================================  =====================

So a member cannot put on another's keys (a forged position is dropped where it enters),
and of the per-node keys it reads only its own inbox (another's is never sent to it, nor
may it subscribe to one); property cells stay readable by every member. A router's
certificate (role ``router``) gets the whole fleet prefix: routers forward for everyone.
An id whose certificates are all revoked, or of a role that is no member (``master``),
gets no rule, so nothing it sends or asks for passes.

Zenoh reads the certificate's common name and nothing else of it: it checks no
revocation list (``Roster`` holds who is revoked, ``zenoh_roster`` re-reads it) and
cannot tell two certificates of one id apart.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable
from dataclasses import dataclass
from typing import Any, Final

from objectplaces.security.links import MEMBER_ROLES
from objectplaces.security.pki import Issued
from objectplaces.transport.zenoh_keys import escape_id

__all__ = ["ALL_MESSAGES", "Roster", "fleet_access_control", "roster_of", "secret_access_control"]

ALL_MESSAGES: Final = (
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "declare_queryable",
    "reply",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
)
"""Every message kind Zenoh's access control knows (Zenoh 1.x)."""


@dataclass(frozen=True, slots=True)
class Roster:
    """Who holds a current certificate of the fleet, by role, and who is revoked.

    Attributes:
        members: ids with a current certificate of a member role (``MEMBER_ROLES``), sorted.
        routers: ids with a current router certificate, sorted.
        revoked: ids that were issued certificates and hold no current one, sorted.
    """

    members: tuple[str, ...] = ()
    routers: tuple[str, ...] = ()
    revoked: tuple[str, ...] = ()


def roster_of(issued: Iterable[Issued], revoked_serials: Collection[int]) -> Roster:
    """The roster of a fleet whose CA issued ``issued`` (``members.json``) and whose
    revocation list names ``revoked_serials``: a certificate marked revoked in either
    is not current."""
    entries = list(issued)
    current = [e for e in entries if e.revoked is None and e.serial not in revoked_serials]
    holders = {e.node_id for e in current}
    return Roster(
        members=tuple(sorted({e.node_id for e in current if e.role in MEMBER_ROLES})),
        routers=tuple(sorted({e.node_id for e in current if e.role == "router"})),
        revoked=tuple(sorted({e.node_id for e in entries} - holders)),
    )


def _rule(rule_id: str, flow: str, messages: Iterable[str], keys: Iterable[str]) -> dict[str, Any]:
    return {
        "id": rule_id,
        "permission": "allow",
        "flows": [flow],
        "messages": list(messages),
        "key_exprs": list(keys),
    }


def _common_rules(p: str) -> list[dict[str, Any]]:
    """What every member may do alike: hear cells and broadcasts, ask, see who is alive."""
    return [
        _rule(
            "members-subscribe", "ingress", ["declare_subscriber"], [f"{p}/props/**", f"{p}/all/*"]
        ),
        _rule(
            "members-liveliness",
            "ingress",
            ["declare_liveliness_subscriber", "liveliness_query"],
            [f"{p}/alive/**"],
        ),
        _rule("members-ask", "ingress", ["query"], [f"{p}/who/**"]),
        _rule("members-hear", "egress", ["put"], [f"{p}/props/**", f"{p}/all/*"]),
        _rule(
            "members-see-alive",
            "egress",
            ["liveliness_token", "declare_liveliness_subscriber", "liveliness_query"],
            [f"{p}/alive/**"],
        ),
        _rule(
            "members-see-routes", "egress", ["declare_subscriber", "declare_queryable"], [f"{p}/**"]
        ),
        _rule("members-asked", "egress", ["query"], [f"{p}/who/**"]),
    ]


def _own_rules(p: str, node: str) -> list[dict[str, Any]]:
    """What only ``node`` may do: put on its keys, hold its token, hear its inbox."""
    e = escape_id(node)
    return [
        _rule(
            f"{node} puts",
            "ingress",
            ["put"],
            [f"{p}/props/*/{e}", f"{p}/props/*/{e}/left", f"{p}/all/{e}", f"{p}/to/*/{e}"],
        ),
        _rule(f"{node} inbox", "ingress", ["declare_subscriber"], [f"{p}/to/{e}/*"]),
        _rule(f"{node} token", "ingress", ["liveliness_token"], [f"{p}/alive/{e}/*/*"]),
        _rule(f"{node} answers", "ingress", ["declare_queryable"], [f"{p}/who/*/{e}"]),
        _rule(f"{node} reads", "egress", ["put"], [f"{p}/to/{e}/*"]),
    ]


def fleet_access_control(fleet: str, roster: Roster) -> dict[str, Any]:
    """Zenoh's ``access_control`` giving each member of ``roster`` its own keys of
    ``fleet`` (by certificate common name), routers the whole fleet, others nothing."""
    p = f"objectplaces/{fleet}"
    rules: list[dict[str, Any]] = []
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    if roster.members:
        common = _common_rules(p)
        rules += common
        subjects.append({"id": "members", "cert_common_names": list(roster.members)})
        policies.append({"rules": [r["id"] for r in common], "subjects": ["members"]})
    for node in roster.members:
        own = _own_rules(p, node)
        rules += own
        subjects.append({"id": f"member {node}", "cert_common_names": [node]})
        policies.append({"rules": [r["id"] for r in own], "subjects": [f"member {node}"]})
    if roster.routers:
        for flow in ("ingress", "egress"):
            rules.append(_rule(f"routers {flow}", flow, ALL_MESSAGES, [f"{p}/**"]))
        subjects.append({"id": "routers", "cert_common_names": list(roster.routers)})
        policies.append({"rules": ["routers ingress", "routers egress"], "subjects": ["routers"]})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def secret_access_control(fleet: str, user: str) -> dict[str, Any]:
    """Zenoh's ``access_control`` of plain links on loopback: the one user every holder
    of the fleet secret proves may use the keys of ``fleet``, and nothing else passes."""
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": [
            _rule("fleet ingress", "ingress", ALL_MESSAGES, [f"objectplaces/{fleet}/**"]),
            _rule("fleet egress", "egress", ALL_MESSAGES, [f"objectplaces/{fleet}/**"]),
        ],
        "subjects": [{"id": "fleet", "usernames": [user]}],
        "policies": [{"rules": ["fleet ingress", "fleet egress"], "subjects": ["fleet"]}],
    }
