"""The checks: each a function that returns what it found wrong, in plain words.

Numbers refer to the README's "Guarantees". Two kinds of check:

* judgments of single facts the probes recorded (``judge``), run after every step:
  guarantees 1 and 3, the order and uniqueness half of 5, and callback order;
* checks of the whole world, run after every step (escaped exceptions, guarantee 4 past
  its deadline), at each calm checkpoint (guarantee 2: membership converged; the
  completeness half of 5), and at the end (guarantee 4 for every session; memory).

Never weaken a check to make a seed pass: a failing seed is a finding.
"""

from __future__ import annotations

from collections.abc import Iterable

from tests.soak.probes import (
    Activated,
    Deactivated,
    Fact,
    InGroup,
    InitiatorHeard,
    OutGroup,
    ParticipantHeard,
)
from tests.soak.workload import HOSTILE
from tests.soak.world import LiveSession, World, retransmission_time

__all__ = [
    "callbacks_in_order",
    "channels_complete",
    "convergence_bound",
    "deactivated_on_leave",
    "forget_deadline",
    "initiator_channel_in_order",
    "judge",
    "membership_converged",
    "memory_bounded",
    "no_exception_escaped",
    "nothing_left",
    "only_members_heard",
    "participant_channel_in_order",
    "roles_only_where_registered",
    "state_within_bounds",
    "stopped_sessions_forgotten",
]

MAX_COUNTER_NAMES = 64
"""Distinct drop/event counter names a node may keep: a fixed vocabulary, not per peer."""


def _hostile(sid: str) -> bool:
    return sid.startswith(f"{HOSTILE}#")


# ---------------------------------------------------------------------- single facts


def only_members_heard(fact: InitiatorHeard) -> list[str]:
    """Guarantee 1: an initiator hears only current members of its own session."""
    found = []
    where = f"t={fact.t:.3f} session {fact.sid}"
    if not fact.notified_member:
        found.append(f"G1 {where}: message from {fact.sender}, not a member as notified")
    if not fact.middleware_member:
        found.append(f"G1 {where}: message from {fact.sender}, not in the role's members")
    if fact.sender_session != fact.sid:
        found.append(f"G1 {where}: message from {fact.sender} of session {fact.sender_session}")
    if fact.tag is not None and fact.tag != fact.sid:
        found.append(f"G1 {where}: message from {fact.sender} sent in session {fact.tag}")
    return found


def initiator_channel_in_order(fact: InitiatorHeard) -> list[str]:
    """Guarantee 5: what one participant role sent arrives in order, once."""
    if fact.tag is None or fact.sender == HOSTILE or fact.k == fact.expected_k:
        return []
    return [
        f"G5 t={fact.t:.3f} session {fact.sid}: from {fact.sender} instance {fact.inst} got "
        f"message {fact.k}, expected {fact.expected_k} (lost, duplicated or reordered)"
    ]


def participant_channel_in_order(fact: ParticipantHeard) -> list[str]:
    """Guarantee 5 and deactivation: a role hears its initiator in order, once, while active."""
    where = f"t={fact.t:.3f} {fact.node} instance {fact.inst} session {fact.sid}"
    found = []
    if not fact.active:
        found.append(f"G4 {where}: a message reached a deactivated role")
    if _hostile(fact.sid) or fact.tag is None:
        return found
    if fact.tag != fact.sid:
        found.append(f"G1 {where}: got a message sent in session {fact.tag}")
    if fact.expected_gen is not None and fact.gen != fact.expected_gen:
        found.append(
            f"G5 {where}: message of membership {fact.gen} after {fact.expected_gen}: "
            "two activations share one role"
        )
    if fact.k != fact.expected_k:
        found.append(
            f"G5 {where}: got message {fact.k}, expected {fact.expected_k} "
            "(lost, duplicated or reordered)"
        )
    return found


def roles_only_where_registered(fact: Activated) -> list[str]:
    """Guarantee 3: a role is activated only under a name registered on its node, and only
    for a session that asked for that name; each instance once."""
    where = f"t={fact.t:.3f} {fact.node} instance {fact.inst} session {fact.sid}"
    found = []
    if fact.role not in fact.registered:
        found.append(f"G3 {where}: role {fact.role!r} active, registered {sorted(fact.registered)}")
    if fact.requested is not None and fact.role != fact.requested:
        found.append(f"G3 {where}: role {fact.role!r} active, the session asked {fact.requested!r}")
    if not fact.fresh:
        found.append(f"G3 {where}: in_group_of twice on one role instance")
    return found


def callbacks_in_order(fact: InGroup | OutGroup | Deactivated) -> list[str]:
    """Guarantee 3 (never told of a decliner) and the order of membership callbacks."""
    match fact:
        case InGroup() if not fact.accepted_before:
            return [
                f"G3 t={fact.t:.3f} session {fact.sid}: in_group for {fact.node}, "
                "where no role was activated (it declined)"
            ]
        case InGroup() if fact.already_member:
            return [f"t={fact.t:.3f} session {fact.sid}: in_group twice for {fact.node}"]
        case OutGroup() if not fact.was_member:
            return [f"t={fact.t:.3f} session {fact.sid}: out_group for non-member {fact.node}"]
        case Deactivated() if not fact.was_active:
            return [
                f"t={fact.t:.3f} {fact.node} instance {fact.inst} session {fact.sid}: "
                "out_group_of twice"
            ]
    return []


def judge(facts: Iterable[Fact]) -> list[str]:
    """Every single-fact check, over ``facts``."""
    found: list[str] = []
    for fact in facts:
        match fact:
            case InitiatorHeard():
                found += only_members_heard(fact) + initiator_channel_in_order(fact)
            case ParticipantHeard():
                found += participant_channel_in_order(fact)
            case Activated():
                found += roles_only_where_registered(fact)
            case InGroup() | OutGroup() | Deactivated():
                found += callbacks_in_order(fact)
    return found


# ---------------------------------------------------------------------- the world


def forget_deadline(world: World) -> float:
    """How long after a stop (or a departure) nothing of a session may remain.

    The deactivation is retransmitted until acknowledged or the channel gives up; a
    participant that hears nothing more of its initiator drops it after the failure
    timeout (longer for an initiator at rest). Either way, this is the longest it can
    take.
    """
    lease = world.config.longest_lease
    assert lease is not None  # every seed detects failures
    return lease + retransmission_time(world.config) + 1.0


CONVERGENCE_TRANSMISSIONS = 8
"""Transmissions of a channel frame a calm network is allowed before membership must
have converged: at the worst loss of a run (20% each way, so 36% per round trip) a frame
and its ack fail 8 times running with probability 0.36**8 < 3e-4."""


def convergence_bound(world: World) -> float:
    """How long after the network heals membership must equal the truth (guarantee 2).

    A departed node is noticed within the failure timeout (three rest beats for a node
    at rest), a returning one within a few liveness intervals (and a rest beat: a node
    at rest counted failed after lost beats is heard again at its next one);
    activating it takes a channel round trip, which on a lossy link may need
    retransmissions (``CONVERGENCE_TRANSMISSIONS``).
    """
    config = world.config
    lease, interval = config.longest_lease, config.liveness_interval
    assert lease is not None  # every seed detects failures
    assert interval is not None
    return (
        lease
        + 4 * interval
        + (config.rest_beat_interval or 0.0)
        + retransmission_time(config, CONVERGENCE_TRANSMISSIONS)
    )


def _participations(world: World) -> dict[tuple[str, str], int]:
    """(session id, node) -> participant roles active there, over every live node."""
    found: dict[tuple[str, str], int] = {}
    for node in world.live:
        for info in world.node(node).participations():
            key = (info.session_id, node)
            found[key] = found.get(key, 0) + 1
    return found


def stopped_sessions_forgotten(world: World, *, every: bool = False) -> list[str]:
    """Guarantee 4: a stopped session (or one whose initiator is gone) leaves no role and
    no state on any node once ``forget_deadline`` has passed (``every``: check them all)."""
    found = []
    now = world.now
    parts = _participations(world)
    for session in world.sessions.values():
        if session.running:
            continue
        ends = [t for t in (session.stopped_at, session.ended_at) if t is not None]
        since = min(ends)
        if not every and now < since + forget_deadline(world):
            continue
        sid = session.sid
        # A restarted node numbers its sessions afresh: a later session may reuse the id.
        # Its roles were activated after it started; only older ones are this session's.
        successor = _successor(world, session)
        if successor is None:
            still = sorted(node for s, node in parts if s == sid)
            if still:
                found.append(f"G4 t={now:.3f} session {sid} ended: roles still active on {still}")
        probes = sorted(
            node
            for (s, node), part in world.ledger.active.items()
            if s == sid and (successor is None or part.since < successor)
        )
        if probes:
            found.append(f"G4 t={now:.3f} session {sid} ended: never deactivated on {probes}")
        if session.node in world.net.nodes and session.ended is None:
            listed = [i.session_id for i in world.node(session.node).sessions()]
            if sid in listed:
                found.append(f"G4 t={now:.3f} session {sid} stopped but still listed")
    return found


def _successor(world: World, session: LiveSession) -> float | None:
    """When a later session with the same id started (its node restarted), if one did."""
    later = [
        other.started_at
        for other in world.sessions.values()
        if other.sid == session.sid and other.started_at > session.started_at
    ]
    return min(later, default=None)


def no_exception_escaped(world: World) -> list[str]:
    """No exception escapes the middleware: none out of an API call or the network, none
    logged by the middleware (the roles' own ``AppFault`` aside), no frame whose handling
    raised (the simulated network drops such a frame and counts it as "failed")."""
    found = [f"escaped: {what}" for what in world.escaped]
    failed = world.net.stats().dropped.get("failed", 0)
    if failed:
        found.append(f"escaped: handling {failed} frame(s) raised in a node (dropped as failed)")
    return found


def deactivated_on_leave(world: World) -> list[str]:
    """Guarantee 4: a node that leaves gracefully deactivates every role it plays."""
    return [
        f"G4 {node} left with role instance {inst} of session {sid} never deactivated"
        for node, sid, inst in world.left_behind
    ]


def _session_converged(
    world: World, session: LiveSession, parts: set[tuple[str, str]]
) -> list[str]:
    found = []
    sid = session.sid
    truth = world.truth(session)
    notified = frozenset(session.role.current)
    info = {i.session_id: i for i in world.node(session.node).sessions()}.get(sid)
    if info is None:
        return [f"G2 session {sid} is running but its node does not list it"]
    where = f"G2 t={world.now:.3f} session {sid} of {session.node}"
    if notified != truth:
        found.append(
            f"{where}: initiator told {sorted(notified)}, truth {sorted(truth)} "
            f"(missing {sorted(truth - notified)}, extra {sorted(notified - truth)})"
        )
    if info.members != truth:
        found.append(f"{where}: middleware members {sorted(info.members)}, truth {sorted(truth)}")
    if info.pending:
        found.append(f"{where}: still pending {sorted(info.pending)}")
    active = frozenset(node for s, node in parts if s == sid)
    if active != truth:
        found.append(f"{where}: roles active on {sorted(active)}, truth {sorted(truth)}")
    return found


def membership_converged(world: World) -> list[str]:
    """Guarantee 2: once the network healed and nothing moves, every running session's
    members are exactly the nodes that match and accept, at the initiator and at every
    participant; no node plays a role in a session that is not running."""
    parts = _participations(world)
    found = [
        f"G2 {node} plays {n} roles in session {sid}" for (sid, node), n in parts.items() if n > 1
    ]
    running = {s.sid for s in world.running_sessions()}
    for sid, node in sorted(parts):
        if sid not in running:
            found.append(f"G2 t={world.now:.3f} {node} plays a role in {sid}, which is not running")
    for session in world.running_sessions():
        found += _session_converged(world, session, set(parts))
    return found


def channels_complete(world: World) -> list[str]:
    """Guarantee 5: between a member and its initiator, after quiescence everything each
    side sent has arrived (both stayed members; the network healed)."""
    found = []
    for session in world.running_sessions():
        role = session.role
        for node in sorted(role.current):
            part = world.ledger.active.get((session.sid, node))
            if part is None:
                continue  # membership_converged says why
            where = f"G5 t={world.now:.3f} session {session.sid} <-> {node} instance {part.inst}"
            if part.heard != role.sent[node] or (role.sent[node] and part.gen != role.gen[node]):
                found.append(
                    f"{where}: initiator sent {role.sent[node]} (membership {role.gen[node]}), "
                    f"role got {part.heard} (membership {part.gen})"
                )
            got = role.heard.get((node, part.inst), 0)
            if got != part.sent:
                found.append(f"{where}: role sent {part.sent}, initiator got {got}")
    return found


def nothing_left(world: World) -> list[str]:
    """Guarantee 4 and memory, at the end: every session stopped long ago, so no node keeps
    any session, participation, channel, tombstone or role timer."""
    found = stopped_sessions_forgotten(world, every=True)
    for node in world.live:
        activator = world.node(node)
        if activator.sessions() or activator.participations():
            found.append(f"G4 {node} still lists sessions or participations after every stop")
        state_counts = getattr(activator.machine, "state_counts", None)
        if state_counts is None:
            continue  # the core no longer offers it: reported, not guessed at
        left = {name: n for name, n in state_counts().items() if n}
        if left:
            found.append(f"memory: {node} keeps {left} after every session ended")
    return found


def state_within_bounds(world: World) -> list[str]:
    """Memory, mid-run: a node's per-session state is explained by the sessions that run
    or ended within ``forget_deadline``, however long the run has gone on (probes set no
    role timers, so none may exist). Tombstones expire on their own clock and are checked
    at the end (``nothing_left``)."""
    found = []
    recent = [
        s
        for s in world.sessions.values()
        if s.running
        or world.now
        < min(t for t in (s.stopped_at, s.ended_at) if t is not None) + forget_deadline(world)
    ]
    peers = len(world.scenario.roles) + 1  # every id the run may use, and the hostile peer
    for node in world.live:
        state_counts = getattr(world.node(node).machine, "state_counts", None)
        if state_counts is None:
            return []
        counts = state_counts()
        own = sum(1 for s in recent if s.node == node)
        limits = {
            "sessions": own,
            "members": own * peers,
            "closing_channels": own * peers,
            "participations": len(recent),
            "role_timers": 0,
        }
        over = {
            name: (counts[name], limit)
            for name, limit in limits.items()
            if counts.get(name, 0) > limit
        }
        if over:
            found.append(f"memory t={world.now:.3f}: {node} holds (count, bound) {over}")
    return found


PEER_TABLES = ("view", "heard", "indexed", "asked")
"""``machine.footprint()`` tables kept per peer heard: after quiescence, live peers only."""
PEER_LOGS = ("dropped_peers", "logged_peers")
"""``machine.footprint()`` tables kept per peer that sent bad frames: any peer of the run."""


def memory_bounded(world: World) -> list[str]:
    """Memory: after quiescence a node's view and its other per-peer tables hold only
    live nodes (departed ones and the silent hostile peer are forgotten), its tables of
    misbehaving peers at most every id of the run, and its counters a fixed vocabulary."""
    found = []
    live = set(world.live)
    everyone = len(world.scenario.roles) + 1  # every id the run may use, and the hostile peer
    for node in world.live:
        activator = world.node(node)
        stale = sorted(set(activator.view()) - live)
        if stale:
            found.append(f"memory t={world.now:.3f}: {node} still holds {stale} in its view")
        names = activator.stats().counters
        if len(names) > MAX_COUNTER_NAMES:
            found.append(f"memory: {node} keeps {len(names)} counters: {sorted(names)[:8]}...")
        footprint = getattr(activator.machine, "footprint", None)
        if footprint is None:
            continue  # the core no longer offers it: reported, not guessed at
        sizes = footprint()
        limits = {name: len(live) for name in PEER_TABLES} | dict.fromkeys(PEER_LOGS, everyone)
        over = {n: (sizes[n], limit) for n, limit in limits.items() if sizes.get(n, 0) > limit}
        if over:
            found.append(f"memory t={world.now:.3f}: {node} holds (size, bound) {over}")
    return found
