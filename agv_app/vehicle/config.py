"""The tunables of the AGV component (:class:`~agv_app.vehicle.controller.AgvController`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["DEFAULT_ADVANCE_M", "AgvConfig"]

DEFAULT_ADVANCE_M = 3.0
"""How far beyond its locks a request reaches at least, by default (docs/traffic.md,
"Request length")."""


@dataclass(frozen=True, slots=True)
class AgvConfig:
    """Tunables of the AGV component (seconds and metres).

    Attributes:
        t_update: property update interval; the safe time is ``2 * t_update``.
        advance_m: how far beyond the current lock end a request reaches at least.
        dwell: time spent at a pick or drop station.
        retry: wait before asking again after a withdrawn request.
        hull_margin_m: added to the published hull length (rounding, wire margin).
        broadcast: vote with every AGV instead of the collision group.
        yield_after: seconds an AGV that stands where it may not rest (inside a two-way
            run: a dead-end dock) waits for its first lock before it backs off to a
            waiting place (``traffic/deadlock.py``, "Yielding").
        patience: seconds a request held up by someone's lock stays pending before it
            is withdrawn (None: never; it steps aside for the lock's owner instead).
        queue_patience: seconds a request held up by an older request stays pending
            before it is withdrawn (None: never); see docs/traffic.md.
        direction_claims: follow same-direction AGVs through two-way runs that the
            route drives through, holding direction claims on their segments
            (docs/traffic.md, "Capacity: direction claims").
        clear_merges: never rest near the end of a branch that turns into a merge or
            enters a crossing, as if it ended in a keep-clear box
            (:func:`~agv_app.traffic.deadlock.merge_branches`; docs/traffic.md,
            "Merges").
        clear_turn_offs: never rest just past a turn off a one-way lane, with the
            back of the hull still in the lane
            (:func:`~agv_app.traffic.deadlock.turn_offs`; docs/traffic.md, "Turning
            off a one-way lane").
        keep_way_out: never rest on the way out of the route's destination
            (:func:`~agv_app.traffic.deadlock.way_out`) where a request would reach
            the destination from there: the AGV standing there leaves by it
            (docs/traffic.md, "Waiting for a station").
        drive_on_after: seconds an AGV at the last resting place before its
            destination waits for its request into it, held up by a lock, before it
            drives on to a waiting place and comes back (None: never); AGVs queued
            behind it may stand where the destination's AGV must drive to leave
            (docs/traffic.md, "Driving on").
        detour_after: seconds an AGV standing before a fork of its way, short of the
            last resting place before its destination, waits for its request, held up
            by a lock, before it takes another way to its destination from that fork,
            one that avoids the segment it was waiting to drive (None: never); AGVs
            that fill a one-way loop each wait for the one ahead
            (docs/traffic.md, "Taking another way").
        vote_deadline: seconds a member of a request's group may take to answer it at
            all; one silent that long counts as failed (None: wait for ever;
            :mod:`agv_app.traffic.plausibility`).
        check_peers: refuse peers' positions and hull lengths that cannot be true
            (:mod:`agv_app.traffic.plausibility`).
    """

    t_update: float = 1.0
    advance_m: float = DEFAULT_ADVANCE_M
    dwell: float = 5.0
    retry: float = 0.2
    hull_margin_m: float = 0.05
    broadcast: bool = False
    yield_after: float = 15.0
    patience: float | None = None
    queue_patience: float | None = 30.0
    direction_claims: bool = True
    clear_merges: bool = True
    clear_turn_offs: bool = True
    keep_way_out: bool = True
    drive_on_after: float | None = 60.0
    detour_after: float | None = 60.0
    vote_deadline: float | None = 10.0
    check_peers: bool = True
