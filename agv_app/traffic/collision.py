"""Collision avoidance: the paper's mutual exclusion over hull projections.

Roles on ObjectPlaces (DESIGN.md, "The AGV application"):

* :class:`Requester` (initiator) asks every member of its request's collision group
  (``request_group``: the AGVs whose circles meet the box around the requested area;
  the paper's ``circles_overlap`` asks more) to allow a hull projection with a totally
  ordered priority ``(request start time, node id)``; members that join late get the request too;
  members that leave no longer count. It locks only when every current member
  allowed, every node its own view puts in the group is such a member (an activation
  still on its way counts as a missing vote), and the safe time ``2 * t_update`` has
  passed since the session started, or since a circle covering the area went out if
  the request is asked again for no more than before. Then it writes the lock to the
  tuplespace and stops the session. A request asked again whose group lies within
  the session's is asked on the open session (``ask_again``), its members kept.
* :class:`Voter` (participant) allows iff the request overlaps none of its AGV's
  requested or locked projections, or only requested ones of lower priority, and the
  requester's circle, as the voter's view has it, covers the request (the paper asks
  less: the requester in the voter's own group; see ``decide_vote``). Otherwise it defers and
  re-evaluates whenever its AGV's area shrinks (tuplespace notify) and every
  ``recheck`` seconds (its view of the requester may catch up).

A voter that allowed a request must not later win a conflict with it: its own
requests that overlap a request it allowed (until the requester says it ended, an
``end`` message, or ``keep_allowed`` after the voter left its session) get a lower
priority than that one
(:meth:`LockBook.next_priority`). Within that rule a request is asked at the *age* of
the wait it serves (:mod:`agv_app.traffic.fifo`), kept across every request asked
again for the same stretch, so the one that has waited longest wins; a request whose
age differs from its priority carries it (``"g"``).

Fairness and the wait for locks (docs/traffic.md, "Why no circle of waits forms" and
"Bounded waits"):

* A request held up by a *lock* stays pending (``patience`` None), so it keeps its
  place in line and no younger request slips past it. Instead the voter that holds it
  up with a lock inherits its age (``("blocking", ...)``: the AGV's next request
  ranks just above it), and the waiting AGV *steps aside* for that lock's owner only:
  its voter allows the owner's request, withdraws its own and asks again at once,
  ranked below the owner's (at most once per ``recheck``: the node's ``blockers``
  name nobody meanwhile, and the voter defers for priority until its next recheck).
  Once the owner asks again at the inherited age, the allow it was given ends, and the
  AGV that stepped aside asks again at its own age, just behind it.
* A request held up by an *older request* for ``queue_patience`` is asked again at
  once (same age, ``on_outwaited``): the last resort that ends the allows it was given,
  so that a younger AGV whose allow ranks it above its own is no longer held below it.

The bookkeeping all of them share lives in the node's tuplespace
(:mod:`agv_app.traffic.lockbook`). This module is the public face; each job is a module
of its own: the roles (:mod:`~agv_app.traffic.requester`, :mod:`~agv_app.traffic.voter`),
the voter's rule (:mod:`~agv_app.traffic.vote`), the groups
(:mod:`~agv_app.traffic.collision_groups`) and the wire form of a request
(:mod:`~agv_app.traffic.request_wire`).
"""

from __future__ import annotations

from agv_app.traffic.collision_groups import (
    broadcast_group,
    collision_group,
    group_within,
    request_group,
)
from agv_app.traffic.request_wire import request_coords
from agv_app.traffic.requester import Requester
from agv_app.traffic.vote import decide_vote
from agv_app.traffic.voter import Voter

__all__ = [
    "Requester",
    "Voter",
    "broadcast_group",
    "collision_group",
    "decide_vote",
    "group_within",
    "request_coords",
    "request_group",
]
