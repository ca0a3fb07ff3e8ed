"""The AGV application component: drives one vehicle, locking area ahead of it.

The component owns the AGV's node and drives its vehicle through its driver
(:class:`~agv_app.vehicle.driven.DrivenVehicle`, docs/drivers.md). Every simulation
step it reads how far its locks reach *from the tuplespace* (the requester role writes
them there), lets the vehicle drive up to that point, requests the next stretch before
it runs out of locked area, and releases what it has driven over. It publishes its
circle and ``status``, ``task`` and ``last_done`` whenever these change.

:class:`AgvController` holds the AGV's state and its step; each job is a class of its
own that it owns and that works on that state:

* :mod:`agv_app.vehicle.locking`: asking for floor, reviewing a request, locks;
* :mod:`agv_app.vehicle.last_resort`: yielding, driving on, taking another way;
* :mod:`agv_app.vehicle.errands`: tasks, dwelling, going home;
* :mod:`agv_app.vehicle.routing`: setting out on a route;
* :mod:`agv_app.vehicle.publication`: the circle and status it publishes;
* :mod:`agv_app.vehicle.binding`: its node's roles (voter, bidder) and peers;
* :mod:`agv_app.vehicle.config`: its tunables (:class:`AgvConfig`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from mypy_extensions import mypyc_attr

from agv_app.geometry import Area, Pose
from agv_app.layout.blocked import OpenWays
from agv_app.layout.elements import Route
from agv_app.layout.graph import Layout
from agv_app.protocol import MessageTally
from agv_app.tasks.auction import TaskSpec
from agv_app.traffic.central import CentralRequest, CentralScheduler
from agv_app.traffic.collision import Requester
from agv_app.traffic.deadlock import StopPlan, clearance_for
from agv_app.traffic.lockbook import LockBook
from agv_app.traffic.plausibility import PeerWatch
from agv_app.vehicle.battery import SimBattery
from agv_app.vehicle.binding import NodeBinding
from agv_app.vehicle.closures import ways_changed
from agv_app.vehicle.comeback import HandBack, come_back
from agv_app.vehicle.config import DEFAULT_ADVANCE_M, AgvConfig
from agv_app.vehicle.driven import DrivenVehicle
from agv_app.vehicle.driver import VehicleDriver
from agv_app.vehicle.errands import Errands
from agv_app.vehicle.isolation import CutOff
from agv_app.vehicle.kinematics import Vehicle, VehicleSpec
from agv_app.vehicle.last_resort import LastResorts
from agv_app.vehicle.locking import Announced, Locking
from agv_app.vehicle.operations import Operations
from agv_app.vehicle.publication import Circle, Publication
from agv_app.vehicle.routing import Routing
from agv_app.vehicle.service import take_out_of_service
from agv_app.vehicle.sim_driver import SimDriver
from objectplaces import RoleActivator

if TYPE_CHECKING:
    from agv_app.vda5050.charging import Battery

__all__ = ["DEFAULT_ADVANCE_M", "AgvConfig", "AgvController"]


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

    peers: PeerWatch
    """What the AGV believes of its peers' circles (set by :meth:`attach`)."""

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
        self.cut_off = CutOff()
        """Whether the AGV hears nobody of a fleet it heard before (it asks for no floor)."""
        self._on_task_started = on_task_started
        self._on_task_done = on_task_done
        self._on_lock_wait = on_lock_wait
        self._on_last_resort = on_last_resort
        self._relocate = relocate
        self.clearance_m = clearance_for(spec.length_m, spec.width_m)
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
        self._released_at_s = 0.0
        self._stalled = False
        self._first_try: tuple[float, float] | None = None
        self._route_started_at = 0.0
        self._advance = self.config.advance_m
        """How far the next request reaches beyond the locks (shorter while held up)."""
        self._resume: str | None = None
        """Where a yielding AGV goes once it has reached its waiting place."""
        self._hold_until = 0.0
        """The vehicle stands still until then (the dwell ends) though its route is set."""
        self._done_later: str | None = None
        """A task finished at the drop station, reported when the dwell ends."""
        self._announced: Announced | None = None
        """Since when a published circle covers the pending request, its area, claims."""
        self._circle: Circle | None = None
        """The circle in force: the last position and hull length published, and when."""
        self._held = False
        self.in_service = True
        """False once taken out of service: it hands back a task it has not loaded,
        delivers a loaded one, goes home and bids for no task until brought back
        (:meth:`take_out_of_service`)."""
        self.sent_home = False
        """True from :func:`~agv_app.vehicle.service.send_home` until it parks at home:
        it bids for no task meanwhile."""
        self.battery: Battery | None = None if spec.battery is None else SimBattery(spec.battery)
        """Its battery, as the vehicle spec declares it (None: no battery model); the
        simulated fleet drains and charges it (:mod:`agv_app.fleet.chargers`)."""
        self.ways: OpenWays | None = None
        """The open ways while part of the floor is closed (None: all open); the fleet
        sets them (:mod:`agv_app.vehicle.closures`)."""
        self._ways_seen: OpenWays | None = None
        self.blocked_to: str | None = None
        """Where the AGV is going and no open way leads (it stands and waits)."""
        # One object per job, each working on the state above (the module's docstring).
        self.locking = Locking(self)
        self.last_resorts = LastResorts(self)
        self.errands = Errands(self)
        self.routing = Routing(self)
        self.publication = Publication(self)
        self.binding = NodeBinding(self)
        self.operations = Operations(self)
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
        """Bind to ``node`` (at start, or after a restart): roles, observers, first lock
        (:meth:`NodeBinding.attach <agv_app.vehicle.binding.NodeBinding.attach>`)."""
        self.binding.attach(node)

    def _blockers(self) -> frozenset[str]:
        return self.locking.blockers()

    def _step_aside(self) -> None:
        self.locking.step_aside()

    def fail(self) -> None:
        """The node crashed, or the vehicle's driver failed (``vehicle.fault``): the
        vehicle is told to stop where it stands, and the AGV does nothing more."""
        self.binding.fail()

    def restart(self, node: RoleActivator) -> None:
        """Come back on a fresh node where the vehicle stands: forget the task (its
        station has returned it), finish the stretch it was on, then drive home."""
        self.binding.restart(node)

    # -- holding (an operator's stop) -------------------------------------------------------

    def hold(self) -> None:
        """Brake to a standstill within the braking distance and stand there, locks kept.

        The vehicle's limit becomes the point where it comes to rest braking now (never
        past the end of its locks): it brakes as it would for any stop, asks for no
        floor and sets off for nothing until :meth:`release`; the locks it stands in
        stay its own. It bids for no task meanwhile.
        """
        self.operations.hold()

    def release(self) -> None:
        """Drive on after :meth:`hold`: every order goes on where it stood."""
        self.operations.release()

    @property
    def held(self) -> bool:
        """True between :meth:`hold` and :meth:`release`."""
        return self._held

    def take_out_of_service(self) -> None:
        """Take no more tasks: hand back a task not loaded yet, deliver a loaded one,
        then drive home and park there (:mod:`agv_app.vehicle.service`)."""
        take_out_of_service(self)

    def return_to_service(self) -> None:
        """Take tasks again."""
        self.in_service = True

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
        return self.operations.display_status()

    def areas(self) -> tuple[list[Area], Area | None]:
        """Locked projections and the requested one, from the tuplespace."""
        return self.publication.areas()

    def current_hull_length(self) -> float:
        """Distance to the furthest point of locked and requested area and claims, plus
        the margin (:meth:`Publication.current_hull_length
        <agv_app.vehicle.publication.Publication.current_hull_length>`)."""
        return self.publication.current_hull_length()

    def publish(self) -> None:
        """Publish position, hull length and status now."""
        self.publication.publish()

    # -- tasks (TaskAgent) --------------------------------------------------------------

    def bid_for(self, task: TaskSpec) -> float | None:
        """Route distance to the pick station, or None if busy or failed
        (:meth:`Errands.bid_for <agv_app.vehicle.errands.Errands.bid_for>`)."""
        return self.errands.bid_for(task)

    def take(self, task: TaskSpec) -> None:
        """Accept an awarded task (:meth:`Errands.take <agv_app.vehicle.errands.Errands.take>`)."""
        self.errands.take(task)

    def _idle(self, now: float) -> None:
        self.errands.idle(now)

    # -- last resorts (a subclass may narrow when they apply) ----------------------------

    def _must_yield(self, now: float) -> bool:
        return self.last_resorts.must_yield(now)

    def _must_drive_on(self, now: float, requester: Requester | CentralRequest) -> bool:
        return self.last_resorts.must_drive_on(now, requester)

    def _must_detour(self, now: float, requester: Requester | CentralRequest) -> bool:
        return self.last_resorts.must_detour(now, requester)

    # -- driving ------------------------------------------------------------------------

    def _route_for(self, dest: str) -> Route:
        """The route from the point we rest on to ``dest``: the shortest one (an order
        from a master control names its own)."""
        return self.way(self.point, dest)

    def way(self, a: str, b: str) -> Route:
        """The shortest route ``a -> b`` over the open ways."""
        return self.layout.route(a, b) if self.ways is None else self.ways.route(a, b)

    def distance(self, a: str, b: str) -> float:
        """The shortest driving distance ``a -> b`` over the open ways."""
        return self.layout.distance(a, b) if self.ways is None else self.ways.distance(a, b)

    def step(self, dt: float) -> None:
        """Advance the AGV by ``dt`` seconds of simulated time."""
        if self.failed:
            self.vehicle.coast(dt)  # told to stop, it brakes on
            return
        if self.ways is not self._ways_seen:
            self._ways_seen = self.ways
            ways_changed(self)
        now = self.node.now()
        vehicle = self.vehicle
        if self._done_later is not None and now >= self._hold_until:
            self.errands.report_done()
        if self._dest is not None:
            limit = vehicle.s if now < self._hold_until else self.book.lock_end(default=vehicle.s)
            if self._held:
                limit = min(limit, self.operations.held_limit())
            moved = vehicle.step(dt, limit)
            self._stalled = moved == 0.0 and not self._held  # held, it wants to stand
            self.locking.step(now)
            if vehicle.speed == 0.0 and vehicle.remaining() < 1e-6:
                self.locking.release()
                self.errands.arrived(now)
        else:
            self._stalled = False
            vehicle.stand(dt)
            if not self._held and (self.blocked_to is None or self.pending_task is not None):
                self._idle(now)  # waiting for a way home, it may set off with a task
        self.binding.rest_when_parked()
        if vehicle.fault is not None:
            self.fail()  # its runner takes the node off the network

    @property
    def at_rest(self) -> bool:
        """True while the AGV is parked at its home with no task (its node beats less
        often then: ``FleetConfig.rest_beat``)."""
        return self.binding.at_rest

    @property
    def stalled(self) -> bool:
        """True while the AGV wants to move and did not move in its last step."""
        return self._stalled
