"""The AGV application component: drives one vehicle, locking area ahead of it.

The component owns the AGV's node and drives its vehicle through its driver
(:class:`~agv_app.vehicle.driven.DrivenVehicle`, docs/drivers.md). Every simulation
step it reads how far its locks reach *from the tuplespace* (the requester role writes
them there), lets the vehicle drive up to that point, requests the next stretch before
it runs out of locked area, and releases what it has driven over. It
publishes its circle, ``position`` and ``hull_length`` (distance to the furthest point
of its locked and requested projections and claims, plus a small margin for rounding),
when a request reaches beyond the circle in force or the circle would be much smaller,
and ``status``, ``task`` and ``last_done`` whenever these change; the middleware's
beats and republications are the heartbeat.

It plays the voter (:mod:`agv_app.traffic.collision`) and bidder
(:mod:`agv_app.tasks.auction`) roles, keeps stale-node records of failed AGVs, and
carries out tasks: to the pick station, dwell, to the drop station, dwell, home to its
own parking spot. It is free for the next task as soon as it dwells at the drop station
(it bids from there and, awarded, sets off for the next pick without going home); one
awarded a task on its way home stops at the first point ahead from which the pick
station is nearer than by way of home, and sets off from there.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NamedTuple

from mypy_extensions import mypyc_attr

from agv_app.geometry import Area, Polyline, Pose, hull_length, hull_projection, projection_ahead
from agv_app.layout.elements import NoRouteError, Route
from agv_app.layout.graph import Layout
from agv_app.protocol import AGV_KIND, MessageTally
from agv_app.tasks.auction import Bidder, TaskSpec
from agv_app.traffic.central import CentralRequest, CentralScheduler
from agv_app.traffic.collision import (
    Requester,
    Voter,
    broadcast_group,
    request_group,
)
from agv_app.traffic.deadlock import (
    Claim,
    StopPlan,
    clearance_for,
    followable_segments,
    merge_branches,
    turn_offs,
)
from agv_app.traffic.fifo import allows_to_revoke, priority_at, ranks_higher, wait_age
from agv_app.traffic.lockbook import LockBook, LockEntry, RequestEntry, StaleRecord
from agv_app.traffic.plausibility import PeerWatch
from agv_app.vehicle.battery import SimBattery
from agv_app.vehicle.comeback import HandBack, come_back
from agv_app.vehicle.driven import DrivenVehicle
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.isolation import CutOff
from agv_app.vehicle.kinematics import Vehicle, VehicleSpec
from agv_app.vehicle.sim_driver import SimDriver
from objectplaces import RoleActivator
from objectplaces.groups import GroupDefinition
from tuplespace import ANY

if TYPE_CHECKING:
    from agv_app.vda5050.charging import Battery

__all__ = ["DEFAULT_ADVANCE_M", "AgvConfig", "AgvController"]

_LEAD_M = 0.01  # a short piece in the old heading, so the first turn is swept and locked
_MIN_ADVANCE_M = 1.25  # the shortest stretch a request held up by a lock shrinks to
_DEPART_SLACK_S = 0.2  # a request before departure starts this much before the safe time

_SHRINK_WORTH_M = 5.0  # a circle this much smaller is worth a publication to every listener

DEFAULT_ADVANCE_M = 3.0
"""How far beyond its locks a request reaches at least, by default (docs/traffic.md,
"Request length")."""

_Announced = tuple[float, Area, frozenset[Claim]]
"""Since when a published circle covers a request, its area and direction claims."""


class _Circle(NamedTuple):
    """A circle the AGV published: centre, hull length, and when it went out."""

    x: float
    y: float
    radius: float
    since: float


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


@mypyc_attr(allow_interpreted_subclasses=True)
class AgvController:
    """One AGV: vehicle, route, locks, task.

    Args:
        node: the AGV's node.
        layout: the floor plan.
        spec: vehicle size and limits.
        home: point id of its parking spot (where it rests).
        start: point id where it stands at first (default: ``home``); it drives home.
        heading_rad: its heading where it starts.
        driver: the vehicle's driver; it stands where the driver says, and the AGV
            comes back there (:func:`~agv_app.vehicle.comeback.come_back`; ``start``
            and ``heading_rad`` go unused). None: the simulated kinematics at
            ``start``.
        config: tunables.
        tally: counts protocol messages.
        on_task_started: called with the task id when the AGV sets off with a task.
        on_task_done: called with the task id when a task is finished.
        on_lock_wait: called with the seconds a granted request waited.
        on_last_resort: called with ``"yield"`` when the AGV backs off from the start of
            its route to a waiting place, ``"drive_on"`` when it drives on past its
            destination to come back later (docs/traffic.md).
        relocate: asked for another parking point when the idle AGV stands in someone's
            way, or when it must yield and its home is no waiting place (None: stay).
        central: grant locks through this central scheduler instead of asking the
            collision group (the baseline, :mod:`agv_app.traffic.central`).
    """

    def __init__(
        self,
        node: RoleActivator,
        layout: Layout,
        spec: VehicleSpec,
        home: str,
        *,
        start: str | None = None,
        heading_rad: float = 0.0,
        config: AgvConfig | None = None,
        tally: MessageTally | None = None,
        on_task_started: Callable[[str], None] | None = None,
        on_task_done: Callable[[str], None] | None = None,
        on_lock_wait: Callable[[float], None] | None = None,
        on_last_resort: Callable[[str], None] | None = None,
        relocate: Callable[[AgvController], str | None] | None = None,
        central: CentralScheduler | None = None,
        driver: VehicleDriver | None = None,
    ) -> None:
        self.layout = layout
        self.node = node
        self.point = home if start is None else start
        p = layout.point(self.point)
        self._vehicle = DrivenVehicle(
            driver or SimDriver(spec, Pose(p.x, p.y, heading_rad)),
            spec,
            clock=lambda: self.node.now(),
        )
        self.spec = spec = self._vehicle.spec
        """The size and limits the traffic control plans with: the vehicle's, as its
        driver declares them (:func:`~agv_app.vehicle.driven.planning_spec`)."""
        self.home = home
        self.config = config or AgvConfig()
        self.tally = tally
        self.distrust: dict[str, int] = {}
        """What this AGV refused to believe of its peers, and how often (positions,
        hull lengths, voters counted as failed: :mod:`agv_app.traffic.plausibility`)."""
        self._max_peer_hull: float | None = None
        self.cut_off = CutOff()
        """Whether the AGV hears nobody of a fleet it heard before (it asks for no floor)."""
        self._on_task_started = on_task_started
        self._on_task_done = on_task_done
        self._on_lock_wait = on_lock_wait
        self._on_last_resort = on_last_resort
        self._relocate = relocate
        self.clearance_m = clearance_for(spec.length_m, spec.width_m)
        self._followable = (
            followable_segments(layout) if self.config.direction_claims else frozenset()
        )
        self._merges = merge_branches(layout) if self.config.clear_merges else frozenset()
        self._turns = turn_offs(layout) if self.config.clear_turn_offs else frozenset()
        # The hull clear of the lane a branch joins: half its length plus half a width.
        self._merge_box_m = (spec.length_m + spec.width_m) / 2
        self.failed = False
        self.handed_back: HandBack | None = None
        """The task the AGV held before its process restarted, handed back to the
        transport base (:mod:`agv_app.vehicle.comeback`)."""
        self.task: TaskSpec | None = None
        self.pending_task: TaskSpec | None = None
        self.phase = "home"
        """``home``, ``to_home``, ``to_pick``, ``at_pick``, ``to_drop`` or ``at_drop``."""
        self.last_done: str | None = None
        self._plan: StopPlan | None = None
        self._route: Route | None = None
        self._route_shift = 0.0
        """Arc length of the driven path before the route's first point (the lead piece)."""
        self._dest: str | None = None
        self._dwell_until = 0.0
        self._key = 0
        self._requester: Requester | CentralRequest | None = None
        self._central = central
        self._retry_at = 0.0
        self._next_release = 0.0
        self._released_at_s = 0.0
        self._stalled = False
        self._first_try: tuple[float, float] | None = None
        self._route_started_at = 0.0
        self._asking_again = False
        self._aside_at = -math.inf
        self._advance = self.config.advance_m
        """How far the next request reaches beyond the locks (shorter while held up)."""
        self._resume: str | None = None
        """Where a yielding AGV goes once it has reached its waiting place."""
        self._no_drive_on_until = 0.0
        """No drive-on before then (the last one found no other way on)."""
        self._no_detour_until = 0.0
        """No other way taken before then (the last try was then)."""
        self._hold_until = 0.0
        """The vehicle stands still until then (the dwell ends) though its route is set."""
        self._done_later: str | None = None
        """A task finished at the drop station, reported when the dwell ends."""
        self._announced: _Announced | None = None
        """Since when a published circle covers the pending request, its area, claims."""
        self._circle: _Circle | None = None
        """The circle in force: the last position and hull length published, and when."""
        self._held = False
        self.in_service = True
        """False once taken out of service: it finishes the task it holds, goes home and
        bids for no task until brought back (:meth:`take_out_of_service`)."""
        self._held_route: Polyline | None = None
        self._held_s = 0.0
        """While held: the route the vehicle rests on and the arc length it rests at."""
        self.battery: Battery | None = None if spec.battery is None else SimBattery(spec.battery)
        """Its battery, as the vehicle spec declares it (None: no battery model); the
        simulated fleet drains and charges it (:mod:`agv_app.fleet.chargers`)."""
        self.attach(node)
        if central is not None:
            central.register(self.node_id, lambda: self.book)
        if driver is not None:
            come_back(self)

    @property
    def vehicle(self) -> DrivenVehicle:
        """The vehicle, through its driver."""
        return self._vehicle

    @vehicle.setter
    def vehicle(self, value: DrivenVehicle | Vehicle) -> None:
        # A simulation may set the simulated kinematics itself (``DrivenVehicle.adopt``).
        if isinstance(value, DrivenVehicle):
            self._vehicle = value
        else:
            self._vehicle.adopt(value)

    # -- node -------------------------------------------------------------------------

    @property
    def node_id(self) -> str:
        """The AGV's (and its node's) id."""
        return self.node.node_id

    @property
    def book(self) -> LockBook:
        """The collision bookkeeping in the node's tuplespace."""
        return LockBook(self.node.space)

    def attach(self, node: RoleActivator) -> None:
        """Bind to ``node`` (at start, or after a restart): roles, observers, first lock.

        The AGV stands where it is and locks its own hull without asking: nobody else
        may lock into it (it is inside its last published circle, or, after a failure,
        inside the stale record the others keep of it).
        """
        self.node = node
        self.failed = False
        self._requester = None
        self._at_rest = False  # a new node beats as usual until the AGV parks
        book = self.book
        book.clear()
        self._key += 1
        book.set_locks(LockEntry(self._key, self.vehicle.s, self.vehicle.hull()))
        node.set_participant_factory(
            "voter",
            lambda: Voter(
                view=self.node.view,
                recheck=self.config.t_update / 2,
                blockers=self._blockers,
                step_aside=self._step_aside,
                revoked=self._revoked,
                tally=self.tally,
            ),
        )
        node.set_participant_factory("bidder", lambda: Bidder(self, tally=self.tally))
        self.peers = PeerWatch(
            book,
            node.view,
            top_speed_m_s=self.spec.max_speed_m_s,
            max_hull_length_m=self._largest_hull_length(),
            count=self._distrust,
        )
        if self.config.check_peers:
            node.set_property_check(self.peers.check)
        node.register_node_departure_observer(self._departed)
        node.register_node_property_observer(self._property, names=("hull_length",))
        node.update_node_property("kind", AGV_KIND)
        node.update_node_property("task", None)
        node.update_node_property("last_done", self.last_done)
        node.update_node_property("reached_pick", None)
        node.update_node_property("dropping_at", None)
        self.publish()

    def _blockers(self) -> frozenset[str]:
        """The nodes whose locks hold up our pending request, that a voter of ours steps
        aside for; none for ``t_update / 2`` after we stepped aside: a circle of AGVs
        each holding up the next would otherwise step aside round it at every round
        trip, each step a new request to its whole group."""
        requester = self._requester
        if requester is None or self.node.now() < self._aside_at + self.config.t_update / 2:
            return frozenset()
        return requester.blocked_by

    def _step_aside(self) -> None:
        """A voter of ours allowed the request of a node whose lock holds up ours: ask
        again, ranked below it."""
        self._aside_at = self.node.now()
        self._ask_again()

    def _revoked(self) -> None:
        """An allow this AGV took back counts no more: ask again at the priority its
        age now gives, if that ranks higher (agv_app.traffic.fifo)."""
        requester = self._requester
        if (
            isinstance(requester, Requester)
            and not requester.done
            and ranks_higher(requester.entry, self._age(), self.node_id, self.book)
        ):
            self._ask_again()

    def _ask_again(self) -> None:
        """Withdraw the pending request and make a new one at once (no gap in which
        younger requests would find our area free); its priority is worked out anew."""
        requester = self._requester
        if requester is None:
            return
        prior = self._announced
        # The session stays open: the new request is asked on it if its group lies
        # within the old one's, keeping the members and their channels.
        kept = requester if isinstance(requester, Requester) else None
        self._asking_again = True
        try:
            if kept is not None:
                kept.withdraw(keep_session=True)
            else:
                requester.withdraw()
        finally:
            self._asking_again = False
        self._retry_at = 0.0
        self._request_ahead(self.node.now(), prior, kept)
        if kept is not None:
            kept.close()  # nothing if the new request was asked on it

    def _age(self) -> float:
        """The age of the wait a request serves: when the AGV started waiting for this
        stretch, or the older age of a request its locks hold up (inherited)."""
        assert self._first_try is not None
        return wait_age(self._first_try[1], self.book)

    def _priority_for(self, area: Area) -> tuple[float, str]:
        """The priority of a request over ``area``: its age (:meth:`_age`), ranked below
        the pending requests this node allowed."""
        return priority_at(self._age(), self.node_id, area, self.book)

    def _largest_hull_length(self) -> float:
        # Imported here: reach reads AgvConfig from this module.
        from agv_app.traffic.reach import largest_hull_length

        if self._max_peer_hull is None:
            self._max_peer_hull = largest_hull_length(self.layout, self.spec, self.config)
        return self._max_peer_hull

    def _distrust(self, what: str) -> None:
        self.distrust[what] = self.distrust.get(what, 0) + 1

    def _departed(self, node_id: str, last: Mapping[str, Any]) -> None:
        self.peers.forget(node_id)
        if last.get("kind") != AGV_KIND:
            return
        pos, radius = last.get("position"), last.get("hull_length")
        if isinstance(pos, tuple | list) and isinstance(radius, int | float):
            self.book.add_stale(StaleRecord(node_id, float(pos[0]), float(pos[1]), float(radius)))

    def _property(self, node_id: str, name: str, value: Any) -> None:
        if node_id != self.node_id and name == "hull_length":
            self.book.drop_stale(node_id)

    def fail(self) -> None:
        """The node crashed, or the vehicle's driver failed (``vehicle.fault``): the
        vehicle is told to stop where it stands, and the AGV does nothing more."""
        self.failed = True
        self.vehicle.stop()
        self._requester = None

    def restart(self, node: RoleActivator) -> None:
        """Come back on a fresh node where the vehicle stands: forget the task (its
        station has returned it), finish the stretch it was on, then drive home."""
        self.task = None
        self.pending_task = None
        self._resume = None
        self._done_later = None  # crashed before its dwell at the drop ended: not done
        self._hold_until = 0.0
        self.phase = "to_home" if self._dest is not None else "lost"
        self._requester = None
        self._retry_at = 0.0
        self.vehicle.clear_fault()
        self.attach(node)
        self._released_at_s = self.vehicle.s

    # -- holding (an operator's stop) -------------------------------------------------------

    def hold(self) -> None:
        """Brake to a standstill within the braking distance and stand there, locks kept.

        The vehicle's limit becomes the point where it comes to rest braking now (never
        past the end of its locks): it brakes as it would for any stop, asks for no
        floor and sets off for nothing until :meth:`release`; the locks it stands in
        stay its own. It bids for no task meanwhile.
        """
        if not self._held:
            self._held = True
            self._held_route = None

    def release(self) -> None:
        """Drive on after :meth:`hold`: every order goes on where it stood."""
        self._held = False
        self._held_route = None

    @property
    def held(self) -> bool:
        """True between :meth:`hold` and :meth:`release`."""
        return self._held

    def take_out_of_service(self) -> None:
        """Take no more tasks: the one it holds (and one awarded while it dwells) it
        finishes, then it drives home and parks there."""
        self.in_service = False

    def return_to_service(self) -> None:
        """Take tasks again."""
        self.in_service = True

    def _held_limit(self) -> float:
        """The arc length the held vehicle rests at: where it stopped braking at the
        hold, or, on a route set since (only ever while standing), where it stands."""
        vehicle = self.vehicle
        if self._held_route is not vehicle.route:
            self._held_route = vehicle.route
            self._held_s = vehicle.stopping_s()
        return self._held_s

    # -- properties -------------------------------------------------------------------

    @property
    def status(self) -> str:
        """``idle`` or ``busy``: the property task assignment selects on.

        Idle with no task, and while dwelling at the drop station of its task: it may
        be awarded the next one there (held as ``pending_task``, busy again).
        """
        if self.pending_task is not None:
            return "busy"
        return "idle" if self.task is None or self.phase == "at_drop" else "busy"

    def display_status(self) -> str:
        """A finer state for the dashboard: idle, driving, waiting, loading, stopping or
        stopped (held by the operator), out-of-service (parked, taking no task) or
        failed."""
        if self.failed:
            return "failed"
        if self._held:
            return "stopped" if self.vehicle.speed == 0.0 else "stopping"
        if not self.in_service and self._dest is None and self.task is None:
            return "out-of-service"
        if self.phase in ("at_pick", "at_drop") or self.node.now() < self._hold_until:
            return "loading"
        if self._dest is not None and self.vehicle.speed == 0.0:
            return "waiting"
        if self._dest is not None:
            return "driving"
        return "idle"

    def areas(self) -> tuple[list[Area], Area | None]:
        """Locked projections and the requested one, from the tuplespace."""
        book = self.book
        request = book.request()
        return [e.area for e in book.locks()], None if request is None else request.area

    def current_hull_length(self) -> float:
        """Distance to the furthest point of locked and requested area, plus the margin.

        Claimed two-way segments count too (to their far end, plus half the hull's
        diagonal): whoever might drive them the other way is then in our group.
        """
        pose = self.vehicle.pose()
        return self._reach_from(pose.x, pose.y)

    def _reach_from(self, x0: float, y0: float) -> float:
        """The hull length a circle centred at ``(x0, y0)`` needs, margin included."""
        locks, request = self.areas()
        shapes = locks if request is None else [*locks, request]
        reach = hull_length((x0, y0), shapes)
        book = self.book
        pending = book.request()
        claims = book.claims() | (frozenset() if pending is None else pending.claims)
        if claims:
            half = math.hypot(self.spec.length_m, self.spec.width_m) / 2
            for seg, _ in claims:
                for x, y in self.layout.segment_coords(seg):
                    reach = max(reach, math.hypot(x - x0, y - y0) + half)
        return reach + self.config.hull_margin_m

    def _covered_since(self) -> float | None:
        """When the circle in force was published, if it covers the locks, the pending
        request and the claims; None if they reach beyond it (or none was published)."""
        circle = self._circle
        if circle is None or self._reach_from(circle.x, circle.y) > circle.radius:
            return None
        return circle.since

    def publish(self) -> None:
        """Publish position, hull length and status now."""
        if self.failed:
            return
        pose = self.vehicle.pose()
        node = self.node
        node.update_node_property("position", (pose.x, pose.y))
        # Rounded up to whole millimetres, so the wire's rounding never shrinks it.
        radius = math.ceil(self.current_hull_length() * 1000) / 1000
        node.update_node_property("hull_length", radius)
        self._circle = _Circle(pose.x, pose.y, radius, node.now())
        if node.properties.get("status") != self.status:
            node.update_node_property("status", self.status)

    # -- tasks (TaskAgent) --------------------------------------------------------------

    def bid_for(self, task: TaskSpec) -> float | None:
        """Route distance to the pick station, or None if busy or failed.

        On the way home it is the distance by way of the point the AGV would stop at
        if awarded (:meth:`_turn_point`).
        """
        if self.failed or self._held or not self.in_service or self.status != "idle":
            return None
        pick = self.layout.station(task.pick).point
        if self._dest is None:
            distance = self.layout.distance(self.point, pick)
            return None if math.isinf(distance) else distance
        turn = self._turn_point(pick)
        if turn is not None:
            return turn[2]
        distance = self.layout.distance(self._dest, pick)
        return None if math.isinf(distance) else self.vehicle.remaining() + distance

    def take(self, task: TaskSpec) -> None:
        """Accept an awarded task: go to its pick station as soon as the AGV is at rest
        (on its way home: at the point :meth:`_turn_point` picks)."""
        self.pending_task = task
        self.node.update_node_property("task", task.id)
        self._turn_for_pending()
        self.publish()

    def _turn_point(self, pick: str) -> tuple[str, float, float] | None:
        """Where an AGV driving home best stops to set off for point ``pick``:
        ``(point, arc length, distance to pick by way of it)``, or None when home is
        as good (or no point ahead will do).

        Candidates are the route's points at or beyond everything locked or requested
        (the vehicle can stop there without giving anything back), clear of every
        no-rest zone.
        """
        route, plan, dest = self._route, self._plan, self._dest
        if route is None or plan is None or dest is None or route.end != dest:
            return None
        vehicle, book = self.vehicle, self.book
        reach = book.lock_end(default=vehicle.s)
        pending = book.request()
        if pending is not None:
            reach = max(reach, pending.end_s)
        home_cost = vehicle.remaining() + self.layout.distance(dest, pick)
        best: tuple[str, float, float] | None = None
        for point, offset in zip(route.points[:-1], route.offsets[:-1], strict=True):
            s = offset + self._route_shift
            if s < reach - 1e-9 or any(lo - 1e-6 <= s <= hi + 1e-6 for lo, hi in plan.zones):
                continue
            cost = s - vehicle.s + self.layout.distance(point, pick)
            if cost < home_cost - 1e-6 and (best is None or cost < best[2]):
                best = (point, s, cost)
        return best

    def _turn_for_pending(self) -> None:
        """On the way home with a task awarded: end the route at the turn point."""
        task = self.pending_task
        if task is None or self.phase != "to_home" or self._resume is not None:
            return
        turn = self._turn_point(self.layout.station(task.pick).point)
        if turn is None or self._plan is None or self._route is None:
            return
        point, s, _ = turn
        self.vehicle.shorten_route(s)
        self._plan = self._plan.cut(s)
        # The route ends there too: driving on (``_drive_on``) sets out from its points.
        points = self._route.points
        self._route = self.layout.route_through(points[: points.index(point) + 1])
        self._dest = point

    # -- driving ------------------------------------------------------------------------

    def _route_to(self, dest: str | None) -> bool:
        """Start driving to point ``dest`` (None: stay), from the point we rest on.

        Returns:
            Whether the AGV drives off: False for None or the point it rests on.
        """
        self._dest = dest
        self._stalled = False
        self._first_try = None
        self._route_started_at = self.node.now()
        if dest is None or dest == self.point:
            self._plan = None
            self._dest = None
            return False
        route = self._route_for(dest)
        self._route = route
        heading = self.vehicle.pose().heading_rad
        ahead = route.polyline.piece_heading(0)
        if abs(math.remainder(ahead - heading, math.tau)) > math.pi / 2:
            # The hull is symmetric: facing backwards is the same rectangle, so the
            # vehicle drives off the other way instead of turning on the spot.
            heading += math.pi
        x0, y0 = route.polyline.start
        lead = (x0 - _LEAD_M * math.cos(heading), y0 - _LEAD_M * math.sin(heading))
        path = Polyline([lead, *route.polyline.coords])
        # Start exactly on the lead piece's end (its rounded length, not _LEAD_M): there
        # the vehicle still faces the old way, so its first lock is the hull it stands
        # in and the first request sweeps the turn.
        self._follow(route, path, shift=path.cumulative[1], start_s=path.cumulative[1])
        return True

    def _follow(self, route: Route, path: Polyline, *, shift: float, start_s: float) -> None:
        """Drive ``route`` along ``path``, which has a lead piece of ``shift`` metres
        before it, from ``start_s``: the first lock is the hull the vehicle stands in,
        and the claims it holds are kept until that lock moves."""
        standing = self.book.claims()
        self.vehicle.new_route(path, s=start_s)
        self._route = route
        self._route_shift = shift
        self._plan = self._plan_for(route).shifted(shift)
        self._key += 1
        self.book.set_locks(
            LockEntry(self._key, self.vehicle.s, self.vehicle.hull(), claims=standing)
        )
        self._released_at_s = self.vehicle.s

    def _plan_for(self, route: Route) -> StopPlan:
        """The resting places of ``route`` under this AGV's rules."""
        return StopPlan.for_route(
            self.layout,
            route,
            clearance_m=self.clearance_m,
            followable=self._followable,
            merges=self._merges,
            merge_box_m=self._merge_box_m,
            turns=self._turns,
            way_out_reach_m=self.config.advance_m if self.config.keep_way_out else None,
        )

    def _route_for(self, dest: str) -> Route:
        """The route from the point we rest on to ``dest``: the shortest one (an order
        from a master control names its own)."""
        return self.layout.route(self.point, dest)

    def step(self, dt: float) -> None:
        """Advance the AGV by ``dt`` seconds of simulated time."""
        if self.failed:
            self.vehicle.coast(dt)  # told to stop, it brakes on
            return
        now = self.node.now()
        vehicle = self.vehicle
        if self._done_later is not None and now >= self._hold_until:
            self._report_done()
        if self._dest is not None:
            limit = vehicle.s if now < self._hold_until else self.book.lock_end(default=vehicle.s)
            if self._held:
                limit = min(limit, self._held_limit())
            moved = vehicle.step(dt, limit)
            self._stalled = moved == 0.0 and not self._held  # held, it wants to stand
            requester = self._requester
            if (
                requester is not None
                and not requester.done
                and self.cut_off.isolated(len(self.node.view()))
            ):
                requester.withdraw()  # with nobody to vote, a request would lock alone
            self._request_ahead(now)
            if now >= self._next_release:
                self._next_release = now + self.config.t_update
                if self._requester is not None:
                    self._requester.check()
                    self._review_request(now)
                if vehicle.s > self._released_at_s + 1e-6:
                    self._release()
            if vehicle.speed == 0.0 and vehicle.remaining() < 1e-6:
                self._release()
                self._arrived(now)
        else:
            self._stalled = False
            vehicle.stand(dt)
            if not self._held:
                self._idle(now)
        self._rest_when_parked()
        if vehicle.fault is not None:
            self.fail()  # its runner takes the node off the network

    def _rest_when_parked(self) -> None:
        """Tell the node when the AGV parks at its home with no task, and when it stops:
        parked, it has nothing to say but that it lives, and beats less often."""
        at_rest = (
            self._dest is None
            and self.phase == "home"
            and self.point == self.home
            and self.task is None
            and self.pending_task is None
        )
        if at_rest != self._at_rest:
            self._at_rest = at_rest
            self.node.set_at_rest(at_rest)

    def _review_request(self, now: float) -> None:
        """Withdraw the pending request to yield (see ``_must_yield``), take back the
        allows that let younger requests over its floor go first, ask for less while a
        lock holds it up, or ask again if it would now rank higher (an inherited age, or
        an allow that ranked it lower ended: agv_app.traffic.fifo).

        Held up by a lock, it asks again to rank higher only without ``patience``,
        which asking again would restart.
        """
        requester = self._requester
        if requester is None or requester.done or self._held:
            return  # held: it stands where it is, and yields or detours for nobody
        if requester.blocked_by and (
            (self._must_yield(now) and self._yield_place() is not None)
            or self._must_drive_on(now, requester)
            or self._must_detour(now, requester)
        ):
            requester.withdraw()
            return
        if isinstance(requester, Requester):
            # Allows given to younger requests over our floor let them go first: take
            # them back, but not those of the AGVs whose locks are in our way.
            entry = requester.entry
            for session in allows_to_revoke(
                self._age(), self.node_id, entry.area, self.book, requester.blocked_by, entry.claims
            ):
                self.book.revoke(session, lease=2 * self.config.t_update)
        if requester.blocked_by:
            if self._may_shorten():
                # Held up by a lock while standing: ask for half the stretch, which
                # may fit behind the AGV ahead (followers close up on a full lane).
                self._advance = max(_MIN_ADVANCE_M, self._advance / 2)
                self._ask_again()
                return
            if self.config.patience is not None:
                return
        if ranks_higher(requester.entry, self._age(), self.node_id, self.book):
            self._ask_again()

    def _may_shorten(self) -> bool:
        """True if the standing AGV's pending request may be asked again shorter."""
        return (
            self.config.patience is None
            and self.vehicle.speed == 0.0
            and self._advance > _MIN_ADVANCE_M
        )

    @property
    def at_rest(self) -> bool:
        """True while the AGV is parked at its home with no task (its node beats less
        often then: ``FleetConfig.rest_beat``)."""
        return self._at_rest

    @property
    def stalled(self) -> bool:
        """True while the AGV wants to move and did not move in its last step."""
        return self._stalled

    def _announced_at(
        self, now: float, area: Area, claims: frozenset[Claim], prior: _Announced | None
    ) -> float:
        """Since when a published circle covers ``area``: ``now``, or, asked again for
        no more than the withdrawn request (area and claims), the time that request's
        circle went out: every circle published while it was pending covered it too."""
        if prior is None:
            return now
        since, before, claimed = prior
        if not claims <= claimed or not before.geom.buffer(1e-6).covers(area.geom):
            return now
        return since

    def _request_ahead(
        self, now: float, prior: _Announced | None = None, kept: Requester | None = None
    ) -> None:
        if self._requester is not None or self._plan is None or now < self._retry_at or self._held:
            return
        if self.cut_off.isolated(len(self.node.view())):
            return  # it hears nothing: it drives on inside its locks only, and stops
        vehicle, spec, book = self.vehicle, self.spec, self.book
        lock_end = book.lock_end(default=vehicle.s)
        if lock_end >= self._plan.length - 1e-9:
            return
        safe_time = 2 * self.config.t_update
        need = spec.braking_distance(spec.max_speed_m_s) + spec.max_speed_m_s * (safe_time + 0.5)
        if lock_end - vehicle.s > need:
            return
        follow = self.config.direction_claims
        end = self._plan.next_stop(lock_end, self._advance, follow=follow)
        if self._advance < self.config.advance_m and not self._plan.may_rest(end):
            # A shortened request ends only where the AGV may rest outside every run,
            # never inside one it follows through (at a dead-end start that place can
            # be with the hull still in the lane it joins).
            end = self._plan.next_stop(lock_end, self.config.advance_m, follow=follow)
        claims = self._plan.claims_between(lock_end, end) if follow else frozenset()
        area = hull_projection(
            vehicle.route, lock_end, end, length=spec.length_m, width=spec.width_m
        )
        if book.hits_stale(area):
            self._retry_at = now + self.config.retry
            return
        self._key += 1
        if self._first_try is None or self._first_try[0] != lock_end:
            self._first_try = (lock_end, now)
        age = self._age()
        priority = priority_at(age, self.node_id, area, book, claims)
        entry = RequestEntry(self._key, end, area, priority, claims, age)
        book.add_request(entry)
        # A request inside the circle in force needs no new one: the others have had
        # it since it went out (docs/traffic.md, "A request inside the published circle").
        covered_since = self._covered_since()
        if covered_since is None:
            self.publish()
            covered_since = now
        announced_at = min(covered_since, self._announced_at(now, area, claims, prior))
        self._announced = (announced_at, area, claims)
        if self._central is not None:
            request = self._central.submit(
                self.node_id, entry, lambda outcome: self._request_done(request, outcome)
            )
            self._requester = request
            request.check()
            return
        definition = self._group_of(area, claims)
        if kept is not None:
            if kept.ask_again(entry, definition, announced_at=announced_at):
                self._requester = kept
                return
            kept.close()
        requester = Requester(
            entry,
            safe_time=safe_time,
            patience=self.config.patience,
            queue_patience=self.config.queue_patience,
            group_view=lambda: self.node.view_group(definition),
            on_done=lambda outcome: self._request_done(requester, outcome),
            tally=self.tally,
            announced_at=announced_at,
            definition=definition,
            vote_deadline=self.config.vote_deadline,
            on_silent=self.peers.silent,
            on_outwaited=self._ask_again,
        )
        self._requester = requester
        self.node.start_interaction(requester, definition, "voter")

    def _group_of(self, area: Area, claims: frozenset[Claim]) -> GroupDefinition:
        """The group a request asks: every AGV in broadcast mode, else the AGVs whose
        circles meet the area or the claimed segments (``request_group``)."""
        if self.config.broadcast:
            return broadcast_group()
        claimed = [xy for seg, _ in claims for xy in self.layout.segment_coords(seg)]
        return request_group(area, claimed)

    def _request_done(self, requester: Requester | CentralRequest, outcome: str) -> None:
        if self._requester is not requester:
            return
        self._requester = None
        now = self.node.now()
        if outcome == "locked":
            self._advance = self.config.advance_m
            if self._on_lock_wait is not None and self._first_try is not None:
                self._on_lock_wait(now - self._first_try[1])
        elif not self._asking_again:
            self._retry_at = now + self.config.retry
            if requester.blocked_by and self._must_yield(now):
                self._yield()
            elif requester.blocked_by and self._must_drive_on(now, requester):
                self._drive_on()
            elif requester.blocked_by and self._must_detour(now, requester):
                self._detour()
            self.publish()

    def _must_yield(self, now: float) -> bool:
        """True if the AGV has not left its start, stands where it may not rest, and has
        waited ``yield_after`` for its first lock: someone needs the run it stands in."""
        plan, vehicle = self._plan, self.vehicle
        return (
            plan is not None
            and self._resume is None
            and self.point != self.home  # its home is a waiting place already
            and vehicle.s <= _LEAD_M + 1e-6
            and self.book.lock_end(default=vehicle.s) <= vehicle.s + 1e-6
            and not plan.may_rest(vehicle.s)
            and now - self._route_started_at >= self.config.yield_after
        )

    def _yield_place(self) -> str | None:
        """Where yielding would take the AGV: its home, else a free rest point (which
        becomes its home); None where there is no such place (every rest point taken).
        Without one, a pending request is kept: withdrawn, it only started again."""
        dest = self._dest
        place: str | None = self.home
        if place in (self.point, dest) and self._relocate is not None:
            place = self._relocate(self)
            if place is not None:
                self.home = place
        return None if place is None or place in (self.point, dest) else place

    def _yield(self) -> None:
        """Back off to a waiting place (home, else a free rest point), then go on."""
        dest = self._dest
        assert dest is not None
        place = self._yield_place()
        if place is None:
            return
        phase = self.phase
        self._route_to(place)
        self.phase = phase
        self._resume = dest
        if self._on_last_resort is not None:
            self._on_last_resort("yield")

    def _must_drive_on(self, now: float, requester: Requester | CentralRequest) -> bool:
        """True if the AGV stands on its way, past its start, at the last resting place
        before its destination, and its request into the destination has been held up
        for ``drive_on_after`` (docs/traffic.md, "Driving on")."""
        after, plan, first = self.config.drive_on_after, self._plan, self._first_try
        return (
            after is not None
            and plan is not None
            and self._resume is None
            and self.vehicle.speed == 0.0
            and self.vehicle.s > self._route_shift + 1e-6
            and requester.entry.end_s >= plan.length - 1e-9
            and first is not None
            and now - first[1] >= after
            and now >= self._no_drive_on_until
        )

    def _drive_on(self) -> bool:
        """Drive on from the next point of the route to a waiting place (home, else a
        free rest point), then come back to the destination from there; False (and
        no new try for ``drive_on_after``) where there is no other way on."""
        route, dest = self._route, self._dest
        assert route is not None
        assert dest is not None
        found = self._onward(route, dest)
        if found is None:
            assert self.config.drive_on_after is not None
            self._no_drive_on_until = self.node.now() + self.config.drive_on_after
            return False
        self._take(*found, "drive_on")
        self._resume = dest
        return True

    def _must_detour(self, now: float, requester: Requester | CentralRequest) -> bool:
        """True if the AGV stands on its way, past its start and short of the last
        resting place before its destination, within a hull length of the route's next
        point, and its request has been held up for ``detour_after`` (docs/traffic.md,
        "Taking another way")."""
        after, plan, first, route = (
            self.config.detour_after,
            self._plan,
            self._first_try,
            self._route,
        )
        vehicle = self.vehicle
        if (
            after is None
            or plan is None
            or route is None
            or self._resume is not None
            or vehicle.speed != 0.0
            or vehicle.s <= self._route_shift + 1e-6
            or requester.entry.end_s >= plan.length - 1e-9
            or first is None
            or now - first[1] < after
            or now < self._no_detour_until
        ):
            return False
        ahead = self._next_point(route)
        if ahead >= len(route.points) - 1:
            return False
        return route.offsets[ahead] + self._route_shift - vehicle.s <= self.spec.length_m

    def _detour(self) -> bool:
        """Take another way to the destination from the route's next point, one that
        drives neither the segment it was waiting to drive nor the one it stands on;
        False where there is none. Either way no new try for ``detour_after``."""
        route, dest = self._route, self._dest
        assert route is not None
        assert dest is not None
        assert self.config.detour_after is not None
        self._no_detour_until = self.node.now() + self.config.detour_after
        ahead = self._next_point(route)
        avoid = {route.segments[ahead], *route.segments[ahead - 1 : ahead]}
        try:
            onward = self.layout.route_avoiding(route.points[ahead], dest, avoid)
        except NoRouteError:
            return False
        self._take(ahead, onward, "detour")
        return True

    def _next_point(self, route: Route) -> int:
        """The index of the route's next point ahead of the vehicle (past the last
        point when the vehicle stands on it)."""
        return route.index_at(self.vehicle.s - self._route_shift + 1e-6) + 1

    def _take(self, ahead: int, onward: Route, resort: str) -> None:
        """Leave the route at its point ``ahead`` for ``onward`` (a last resort, counted
        as ``resort``): the lead piece is the rest of the way to that point, and the
        vehicle starts at its beginning, where it stands."""
        route, vehicle = self._route, self.vehicle
        assert route is not None
        lead = vehicle.route.slice(vehicle.s, route.offsets[ahead] + self._route_shift)
        path = Polyline([*lead.coords, *onward.polyline.coords])
        self._follow(onward, path, shift=lead.length, start_s=0.0)
        self._dest = onward.end
        self._stalled = False
        self._first_try = None
        self._advance = self.config.advance_m
        self._route_started_at = self.node.now()
        if self._on_last_resort is not None:
            self._on_last_resort(resort)

    def _onward(self, route: Route, dest: str) -> tuple[int, Route] | None:
        """The index of the route's next point and the way from there to a waiting
        place that does not pass ``dest``, or None."""
        ahead = self._next_point(route)
        via = route.points[min(ahead, len(route.points) - 1)]
        if via == dest:
            return None  # already on the way into it: there is no other way on
        place: str | None = self.home
        if place in (via, dest) and self._relocate is not None:
            place = self._relocate(self)
            if place is not None:
                self.home = place
        if place is None or place in (via, dest):
            return None
        try:
            onward = self.layout.route(via, place)
        except NoRouteError:
            return None
        return None if dest in onward.points else (ahead, onward)

    def _release(self) -> None:
        vehicle, spec, book = self.vehicle, self.spec, self.book
        lock_end = book.lock_end(default=vehicle.s)
        area = projection_ahead(
            vehicle.route, vehicle.s, lock_end, length=spec.length_m, width=spec.width_m
        )
        held = book.claims()
        if self._plan is not None:
            held &= self._plan.claims_held(vehicle.s, lock_end)
        self._key += 1
        book.set_locks(LockEntry(self._key, lock_end, area, held))
        self._released_at_s = vehicle.s
        # Shrinking is optional for safety (the old circle still covers what is left);
        # publish it when it is worth the message: fewer AGVs in our next groups.
        published = self.node.properties.get("hull_length")
        if (
            not isinstance(published, float)
            or self.current_hull_length() < published - _SHRINK_WORTH_M
        ):
            self.publish()

    def _arrived(self, now: float) -> None:
        assert self._dest is not None
        self.point = self._dest
        self._dest = None
        self._plan = None
        self._route = None
        if self._resume is not None:
            # Bound home, it goes to the home it has now: a yield may have moved it to
            # the place it just reached, and the old one is someone else's to take.
            resume = self.home if self.phase == "to_home" else self._resume
            self._resume = None
            if self._route_to(resume):
                self.publish()
                return
        if self.phase in ("to_pick", "to_drop"):
            self._dwell(now)
        else:
            self.phase = "home"
        self.publish()

    def _dwell(self, now: float) -> None:
        """Stand at the station of the task's leg for ``dwell``. The stations hear where
        the AGV is bound (a station calls its next AGV when none is on its way to it):
        at the pick station ``reached_pick`` and the drop station (``dropping_at``),
        at the drop station that it is there."""
        if self.phase == "to_pick":
            self.phase = "at_pick"
            if self.task is not None:
                self.node.update_node_property("reached_pick", self.task.id)
                self.node.update_node_property("dropping_at", self.task.drop)
        else:
            self.phase = "at_drop"
            self.node.update_node_property("dropping_at", None)
        self._dwell_until = now + self.config.dwell

    def _idle(self, now: float) -> None:
        resting = self.phase == "home" and self.point == self.home
        if resting and self.pending_task is None:
            in_the_way = self.node.space.in_all(("in_the_way", ANY))
            if not in_the_way or self._relocate is None:
                return
            home = self._relocate(self)
            if home is None or home == self.home:
                return
            self.home = home
        if self.phase in ("at_pick", "at_drop"):
            if now < self._dwell_until - self._departure_lead():
                return
            # The route is set while the AGV still dwells, so that its first request
            # is granted as the dwell ends; the vehicle stands until then.
            self._hold_until = self._dwell_until
        if self.phase == "at_pick" and self.task is not None:
            self.phase = "to_drop"
            self._route_to(self.layout.station(self.task.drop).point)
        elif self.phase == "at_drop" and self.task is not None:
            self._done_later = self.task.id
            self.task = None
            if now >= self._hold_until:
                self._report_done()
            if self.pending_task is not None:
                self._start_pending()  # awarded while dwelling: no drive home
            else:
                self._go_home()
        elif self.pending_task is not None:
            self._start_pending()
        elif self.phase != "home" or self.point != self.home:
            self._go_home()
        if self._dest is None and self.phase in ("to_pick", "to_drop"):
            self._dwell(now)  # already standing there
        self.publish()

    def _departure_lead(self) -> float:
        """Seconds before the end of a dwell at which the next route is set: the safe
        time a request waits (and a little), none with the central scheduler, which
        grants at once."""
        if self._central is not None:
            return 0.0
        return 2 * self.config.t_update + _DEPART_SLACK_S

    def _report_done(self) -> None:
        """Report the task finished at the drop station (when its dwell ends)."""
        done = self._done_later
        assert done is not None
        self._done_later = None
        self.last_done = done
        self.node.update_node_property("last_done", done)
        # The next task may have been taken (or started) in the meantime.
        current = self.task or self.pending_task
        self.node.update_node_property("task", None if current is None else current.id)
        if self._on_task_done is not None:
            self._on_task_done(done)

    def _start_pending(self) -> None:
        assert self.pending_task is not None
        self.task, self.pending_task = self.pending_task, None
        back, self.handed_back = self.handed_back, None
        loaded = back is not None and back.resumed(self.node, self.task)
        self.phase = "to_drop" if loaded else "to_pick"
        if self._on_task_started is not None:
            self._on_task_started(self.task.id)
        station = self.task.drop if loaded else self.task.pick
        self._route_to(self.layout.station(station).point)

    def _go_home(self) -> None:
        self.phase = "to_home"
        self._route_to(self.home)
        if self._dest is None:
            self.phase = "home"
