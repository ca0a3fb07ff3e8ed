"""The interest radius keeps every possible collider of every request in the requester's
view (agv_app/traffic/reach.py, docs/traffic.md).

After every network step of a scoped fleet, every pair of AGVs whose published circles
overlap hear each other, every published hull length stays within the bound the radius
is built from, and the safety monitor finds nothing. A radius that is too small is
caught by the same check.
"""

from __future__ import annotations

import itertools

import pytest
from hypothesis import HealthCheck, given, settings

from agv_app.fleet import Fleet, FleetConfig, agv_process
from agv_app.fleet.liveness import REST_BEAT_S
from agv_app.fleet.view import OBSERVER_ID
from agv_app.layout import Layout, Point, Segment, Station
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.loop import long_loop
from agv_app.tasks import BASE_ID, pick_stations
from agv_app.traffic.deadlock import StopPlan, clearance_for, followable_segments
from agv_app.traffic.reach import (
    dissemination_margin,
    interest_radius,
    largest_hull_length,
    longest_no_rest_zone,
    unheard_colliders,
)
from agv_app.vehicle.controller import AgvConfig
from agv_app.vehicle.kinematics import VehicleSpec
from tests.agv_app.test_random_layouts import floors
from tests.agv_app.two_way_floors import Floor

SPEC = VehicleSpec(2.0, 1.0)
CLEARANCE = clearance_for(SPEC.length_m, SPEC.width_m)


class ScopeWatch:
    """Checks a fleet after every network step: who hears whom, how far hulls reach."""

    def __init__(self, fleet: Fleet) -> None:
        self.fleet = fleet
        self.missed: list[tuple[float, str, str]] = []
        self.checks = 0
        self.longest_hull = 0.0
        run_for = fleet.net.run_for

        def run_and_check(seconds: float) -> None:
            run_for(seconds)
            self.check()

        fleet.net.run_for = run_and_check  # type: ignore[method-assign]

    def check(self) -> None:
        """Every frame sent in the previous step has arrived: the views are settled."""
        agvs = self.fleet.agvs
        published = {a: agv.node.properties for a, agv in agvs.items() if not agv.failed}
        heard = {a: agv.node.view().keys() for a, agv in agvs.items() if not agv.failed}
        now = self.fleet.now
        self.missed += [(now, a, b) for a, b in unheard_colliders(published, heard)]
        self.checks += 1
        for props in published.values():
            length = props.get("hull_length")
            if isinstance(length, float):
                self.longest_hull = max(self.longest_hull, length)


def _scoped_fleet(
    radius: float | None, seconds: float, *, footprints: bool = True, seed: int = 3
) -> tuple[Fleet, ScopeWatch]:
    config = FleetConfig(
        agvs=12, seed=seed, load=0.5, interest_radius=radius, footprints=footprints
    )
    fleet = Fleet(config=config)
    watch = ScopeWatch(fleet)
    fleet.run(seconds)
    return fleet, watch


@pytest.fixture(scope="module")
def scoped_run() -> tuple[Fleet, ScopeWatch]:
    return _scoped_fleet(None, 150.0)


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
def test_scoped_fleet_hears_every_possible_collider(scoped_run: tuple[Fleet, ScopeWatch]) -> None:
    fleet, watch = scoped_run
    assert fleet.interest_radius is not None
    assert watch.checks == 1500
    assert watch.missed == []
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0
    assert fleet.summary()["tasks_completed"] >= 3


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
def test_published_hull_lengths_stay_within_the_bound(
    scoped_run: tuple[Fleet, ScopeWatch],
) -> None:
    fleet, watch = scoped_run
    bound = largest_hull_length(fleet.layout, fleet.spec, fleet.agv_config)
    assert 4.0 < watch.longest_hull <= bound
    timing = {"delay_s": 0.007, "failure_detection_s": 3 * REST_BEAT_S + 1.0}
    assert fleet.interest_radius == pytest.approx(
        interest_radius(fleet.layout, fleet.spec, fleet.agv_config, footprints=True, **timing)
    )
    margin = dissemination_margin(fleet.spec, fleet.agv_config, **timing)
    assert fleet.footprint_margin == pytest.approx(margin / 2)
    # Without footprints each circle may be the largest: twice it, and the whole margin.
    own_cell = interest_radius(
        fleet.layout, fleet.spec, fleet.agv_config, footprints=False, **timing
    )
    assert own_cell == pytest.approx(2 * bound + margin)


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
def test_a_radius_too_small_is_caught() -> None:
    # A seed whose first minute brings unheard AGVs close (seed 3's does not).
    fleet, watch = _scoped_fleet(6.0, 60.0, footprints=False, seed=4)
    assert fleet.interest_radius == 6.0
    assert watch.missed, "a 6 m radius must leave colliders unheard"
    # And an unheard collider is a real danger: locks granted over each other.
    assert fleet.monitor.lock_overlaps > 0


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
def test_the_base_and_observer_hear_every_node(scoped_run: tuple[Fleet, ScopeWatch]) -> None:
    fleet, _ = scoped_run
    for node_id in [OBSERVER_ID, BASE_ID]:
        assert set(fleet.nodes()[node_id].view()) >= set(fleet.agvs)


def test_broadcast_and_unscoped_fleets_hear_every_node() -> None:
    assert Fleet(config=FleetConfig(agvs=2, broadcast=True)).interest_radius is None
    assert Fleet(config=FleetConfig(agvs=2, scoped=False)).interest_radius is None
    assert Fleet(config=FleetConfig(agvs=2, interest_radius=30.0)).interest_radius == 30.0


@pytest.mark.parametrize("field", ["interest_radius", "heartbeat", "republish", "rest_beat"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("inf")])
def test_config_refuses_bad_radius_and_heartbeat(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        FleetConfig(**{field: value})  # type: ignore[arg-type]


def _sent(
    heartbeat: float | None,
    kind: str,
    *,
    beats: bool = True,
    rest_beat: float | None = None,
    seconds: float = 12.0,
) -> tuple[int, int]:
    config = FleetConfig(
        agvs=2, heartbeat=heartbeat, start_tasks=0, load=0.01, beats=beats, rest_beat=rest_beat
    )
    fleet = Fleet(config=config)
    fleet.run(seconds)
    frames, size = fleet.net.stats().per_node["agv-01"].sent.get(kind, (0, 0))
    return frames, size


def test_a_slower_heartbeat_beats_less() -> None:
    # Idle AGVs publish nothing new: they only beat.
    assert 3 * _sent(5.0, "beat")[0] < _sent(None, "beat")[0]


def test_idle_agvs_beat_instead_of_republishing_every_property() -> None:
    beats, first = _sent(None, "beat"), _sent(None, "property")  # first: the start's
    before = _sent(None, "property", beats=False)
    assert beats[0] + first[0] == before[0]  # a frame a second all the same ...
    assert 5 * beats[1] < before[1] - first[1]  # ... for a fraction of the bytes
    assert _sent(None, "beat", beats=False) == (0, 0)


def test_idle_agvs_republish_every_property_only_every_ten_minutes() -> None:
    """At the defaults the start's publication is all a parked AGV sends of its
    properties for ten minutes: its beats carry the number a receiver checks."""
    first = _sent(None, "property", seconds=5.0)
    assert _sent(None, "property", seconds=595.0) == first
    assert _sent(None, "property", seconds=605.0)[0] > first[0]


def test_parked_agvs_beat_at_the_rest_interval() -> None:
    """Two idle AGVs at home for a minute: three beats a second apart, then one every
    five seconds, instead of one a second (the rest beats are three bytes longer)."""
    usual = _sent(None, "beat", seconds=60.0)  # frames to every listener
    resting = _sent(None, "beat", rest_beat=REST_BEAT_S, seconds=60.0)
    # About 59 beats against 3 + 11 (3 s, then one every 5 s: 8 s, 13 s ...).
    assert 0.2 < resting[0] / usual[0] < 0.3
    assert resting[1] < usual[1] / 2
    # A heartbeat as long as the rest beat leaves nothing to save.
    assert _sent(5.0, "beat", rest_beat=REST_BEAT_S, seconds=60.0) == _sent(
        5.0, "beat", seconds=60.0
    )


@pytest.mark.parametrize("station_nodes", [False, True])
def test_the_stations_and_the_observer_are_at_rest_from_the_start(station_nodes: bool) -> None:
    """They never move and have said all they will at start: three beats a second
    apart, then one every rest interval, as parked AGVs."""

    def beats(rest_beat: float | None) -> dict[str, int]:
        config = FleetConfig(
            agvs=2, start_tasks=0, load=0.01, rest_beat=rest_beat, station_nodes=station_nodes
        )
        fleet = Fleet(config=config)
        fleet.run(60.0)
        per_node = fleet.net.stats().per_node
        quiet = [n for n in fleet.nodes() if n not in fleet.agvs]
        return {node: per_node[node].sent.get("beat", (0, 0))[0] for node in quiet}

    usual, resting = beats(None), beats(REST_BEAT_S)
    # The observer and the base, or the observer and the demo's stations.
    assert len(usual) == (1 + len(pick_stations(demo_warehouse())) if station_nodes else 2)
    for node, frames in resting.items():
        # About 59 beats to each listener against 3 + 11 (3 s, then one every 5 s).
        assert 0.2 < frames / usual[node] < 0.3, (node, frames, usual[node])


def test_an_agv_is_at_rest_only_while_parked_at_home_without_a_task() -> None:
    fleet = Fleet(config=FleetConfig(agvs=6, seed=2, load=0.5))
    seen: set[tuple[bool, str, bool]] = set()
    for _ in range(120):
        fleet.run(1.0)
        for agv in fleet.agvs.values():
            parked = agv.phase == "home" and agv.point == agv.home and agv.vehicle.speed == 0.0
            busy = agv.task is not None or agv.pending_task is not None
            seen.add((agv.at_rest, agv.phase, busy))
            if agv.at_rest:
                assert parked, (agv.node_id, agv.phase, agv.point)
                assert not busy, (agv.node_id, agv.task, agv.pending_task)
            elif parked and not busy and agv._dest is None:
                raise AssertionError(f"{agv.node_id} parked idle but not at rest")
    assert (True, "home", False) in seen
    assert any(not rest and busy for rest, _, busy in seen)


# -- the bound itself -------------------------------------------------------------------


def _longest_zone_and_request(layout: Layout, advance_m: float) -> tuple[float, float]:
    """The longest no-rest zone of every route between any two points, and how far
    beyond its start a request reaches: its end, or the far end of a segment it claims
    (direction claims on, as the AGV drives)."""
    followable = followable_segments(layout)
    zone = request = 0.0
    for a, b in itertools.permutations(sorted(layout.points), 2):
        if layout.distance(a, b) == float("inf"):
            continue
        route = layout.route(a, b)
        plan = StopPlan.for_route(layout, route, clearance_m=CLEARANCE, followable=followable)
        zone = max([zone, *(hi - lo for lo, hi in plan.zones)])
        far_end = {seg: route.offsets[i + 1] for i, seg in enumerate(route.segments)}
        steps = max(1, int(plan.length / 0.25))
        for k in range(steps + 1):
            s = plan.length * k / steps
            for follow in (False, True):
                end = plan.next_stop(s, advance_m, follow=follow)
                claimed = [far_end[seg] for seg, _ in plan.claims_between(s, end)]
                request = max(request, end - s, *(f - s for f in claimed))
    return zone, request


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(floor=floors())
def test_no_route_has_a_longer_zone_or_request_than_the_bound(floor: Floor) -> None:
    advance = AgvConfig().advance_m
    bound = longest_no_rest_zone(floor.layout, CLEARANCE)
    zone, request = _longest_zone_and_request(floor.layout, advance)
    assert zone <= bound + 1e-9
    assert request <= 1.25 * advance + bound + 1e-9


def test_zone_bound_on_a_two_way_lane_between_one_way_stretches() -> None:
    """Two two-way runs joined by a one-way piece shorter than twice the clearance merge."""
    points = [Point(p, x, 0.0) for p, x in (("a", 0.0), ("b", 10.0), ("c", 13.0), ("d", 25.0))]
    points += [Point("e", 12.0, 8.0)]
    segments = [
        Segment("ab", "a", "b", bidirectional=True),
        Segment("bc", "b", "c"),
        Segment("ce", "c", "e"),
        Segment("eb", "e", "b"),
        Segment("cd", "c", "d", bidirectional=True),
    ]
    stations = [Station("sa", "a", "pickdrop"), Station("sd", "d", "pickdrop")]
    layout = Layout(points, segments, stations, name="joined")
    zone, _ = _longest_zone_and_request(layout, AgvConfig().advance_m)
    assert zone == pytest.approx(10.0 + 3.0 + 12.0 + 2 * CLEARANCE)
    assert longest_no_rest_zone(layout, CLEARANCE) >= zone


def test_one_way_layout_has_no_zone_and_demo_radius_is_bounded() -> None:
    points = [Point("a", 0.0, 0.0), Point("b", 10.0, 0.0)]
    layout = Layout(points, [Segment("ab", "a", "b")], [], name="one-way")
    assert longest_no_rest_zone(layout, CLEARANCE) == 0.0
    demo = demo_warehouse()
    x0, y0, x1, y1 = demo.bounds()
    longest = largest_hull_length(demo, SPEC, AgvConfig())
    assert longest <= ((x1 - x0) ** 2 + (y1 - y0) ** 2) ** 0.5 + 2.0
    assert interest_radius(demo, SPEC, AgvConfig(), delay_s=0.01) > 2 * longest


def test_unheard_colliders_finds_overlapping_circles_only() -> None:
    published: dict[str, dict[str, object]] = {
        "a": {"position": (0.0, 0.0), "hull_length": 5.0},
        "b": {"position": (9.0, 0.0), "hull_length": 5.0},
        "c": {"position": (30.0, 0.0), "hull_length": 5.0},
        "d": {"kind": "agv"},
    }
    heard: dict[str, set[str]] = {"a": {"c"}, "b": {"a"}, "c": set(), "d": set()}
    assert unheard_colliders(published, heard) == [("a", "b")]


# -- a floor longer than the radius: the scope really leaves nodes out ------------------


def _long_floor_run(footprints: bool) -> tuple[Fleet, ScopeWatch, float]:
    """12 AGVs on the 300 m loop for 150 s; the mean number of AGVs each AGV hears."""
    config = FleetConfig(agvs=12, seed=5, load=0.6, footprints=footprints)
    fleet = Fleet(long_loop(), config)
    watch = ScopeWatch(fleet)
    heard_counts: list[int] = []
    for _ in range(15):
        fleet.run(10.0)
        for agv in fleet.agvs.values():
            heard_counts.append(len(set(agv.node.view()) & set(fleet.agvs)))
    return fleet, watch, sum(heard_counts) / len(heard_counts)


@pytest.fixture(scope="module")
def long_floor_runs() -> dict[bool, tuple[Fleet, ScopeWatch, float]]:
    return {footprints: _long_floor_run(footprints) for footprints in (False, True)}


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
@pytest.mark.parametrize("footprints", [False, True])
def test_on_a_long_floor_agvs_hear_only_their_neighbourhood(
    long_floor_runs: dict[bool, tuple[Fleet, ScopeWatch, float]], footprints: bool
) -> None:
    fleet, watch, mean_heard = long_floor_runs[footprints]
    assert fleet.interest_radius is not None
    assert fleet.interest_radius < 100.0
    assert (fleet.footprint_margin is not None) == footprints
    assert mean_heard < len(fleet.agvs) - 1, "on a 300 m floor some AGVs are out of scope"
    assert watch.missed == []
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0
    assert fleet.summary()["tasks_completed"] >= 1


@pytest.mark.source_only("replaces SimulatedNetwork.run_for")
def test_footprints_let_an_agv_hear_fewer_agvs(
    long_floor_runs: dict[bool, tuple[Fleet, ScopeWatch, float]],
) -> None:
    own_cell, footprint = long_floor_runs[False][2], long_floor_runs[True][2]
    assert footprint < 0.9 * own_cell, (footprint, own_cell)


# -- the AGV process on the mesh --------------------------------------------------------

_PROCESS_ARGS = ["--id", "agv-1", "--pki", "pki", "--home", "P0350n"]


@pytest.mark.parametrize(
    ("given", "expected"), [(None, "auto"), ("none", "none"), ("40", 40.0), ("12.5", 12.5)]
)
def test_agv_process_takes_an_interest_radius(given: str | None, expected: object) -> None:
    extra = [] if given is None else ["--interest-radius", given]
    assert agv_process.parse_args([*_PROCESS_ARGS, *extra]).interest_radius == expected


@pytest.mark.parametrize("given", ["0", "-3", "far", "inf"])
def test_agv_process_refuses_a_bad_interest_radius(given: str) -> None:
    with pytest.raises(SystemExit):
        agv_process.parse_args([*_PROCESS_ARGS, "--interest-radius", given])


def test_long_loop_is_one_loop_with_two_way_spurs_only() -> None:
    layout = long_loop(100.0)
    assert layout.bounds() == (0.0, 0.0, 100.0, 20.0)
    assert set(layout.usable_stations()) == set(layout.stations)
    assert all(
        "park" in s.id or "dock" in s.id for s in layout.segments.values() if s.bidirectional
    )
    with pytest.raises(ValueError, match="length_m"):
        long_loop(10.0)


# -- failed AGVs beyond the scope ----------------------------------------------------------


def test_an_agv_out_of_scope_learns_of_a_crash_from_the_relay_and_of_the_return() -> None:
    fleet = Fleet(long_loop(), FleetConfig(agvs=12, seed=5, load=0.6, fail_on_violation=True))
    fleet.run(20.0)
    radius = fleet.interest_radius
    assert radius is not None
    assert fleet.stale_relay is not None

    def far_from(agv_id: str) -> list[str]:
        x = fleet.agvs[agv_id].node.properties["position"][0]
        return [
            a
            for a, agv in fleet.agvs.items()
            if abs(agv.node.properties["position"][0] - x) > radius + 30.0
        ]

    crashed = next(a for a in sorted(fleet.agvs) if far_from(a))
    far = far_from(crashed)[0]
    assert crashed not in fleet.agvs[far].node.view()
    fleet.crash(crashed)
    # Found within 4/3 of the 3 s timeout, or of three rest beats if it was parked
    # (NodeConfig.failure_detection_bound), then relayed.
    bound = fleet.agvs[far].node.machine.config.failure_detection_bound
    assert bound == 3 * REST_BEAT_S + 1.0
    fleet.run(bound + 0.5)
    assert crashed in fleet.stale_relay.failed
    assert crashed in {r.node_id for r in fleet.agvs[far].book.stale()}
    fleet.recover(crashed)
    fleet.run(2.0)
    assert crashed not in fleet.stale_relay.failed
    assert crashed not in {r.node_id for r in fleet.agvs[far].book.stale()}
    fleet.run(60.0)
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0


def test_unscoped_fleets_run_no_relay() -> None:
    assert Fleet(config=FleetConfig(agvs=2, scoped=False)).stale_relay is None


def test_the_listener_skips_malformed_records() -> None:
    fleet = Fleet(long_loop(100.0), FleetConfig(agvs=2, seed=1, start_tasks=0))
    fleet.run(1.0)
    observer = fleet.observer
    bad = [["x"], [1, 2.0, 3.0, 4.0], ["agv-02", "a", 0.0, 1.0], "nonsense"]
    observer.update_node_property("failed_agvs", [*bad, ["ghost", 50.0, 10.0, 2.0]])
    fleet.run(0.5)
    assert [r.node_id for r in fleet.agvs["agv-01"].book.stale()] == ["ghost"]
    observer.update_node_property("failed_agvs", [])
    fleet.run(0.5)
    assert fleet.agvs["agv-01"].book.stale() == []


def test_requests_with_direction_claims_stay_within_the_bound() -> None:
    """A two-way run driven through (one-way lanes join both its ends): its segments
    are claimed, and a claim reaches as far as the request's own bound allows."""
    points = [Point("w", 0.0, 0.0), Point("m", 12.0, 0.0), Point("e", 24.0, 0.0)]
    points += [Point("ne", 24.0, 12.0), Point("nw", 0.0, 12.0), Point("d", 12.0, -3.0)]
    segments = [
        Segment("w-m", "w", "m", bidirectional=True),
        Segment("m-e", "m", "e", bidirectional=True),
        Segment("m-d", "m", "d", bidirectional=True),
        Segment("e>ne", "e", "ne"),
        Segment("ne>nw", "ne", "nw"),
        Segment("nw>w", "nw", "w"),
    ]
    layout = Layout(points, segments, [Station("sd", "d", "pickdrop")], name="through")
    assert followable_segments(layout) >= {"w-m", "m-e"}
    advance = AgvConfig().advance_m
    zone, request = _longest_zone_and_request(layout, advance)
    bound = longest_no_rest_zone(layout, CLEARANCE)
    assert zone <= bound
    assert request <= 1.25 * advance + bound


def test_a_floor_too_long_for_the_cells_of_its_radius_is_heard_whole() -> None:
    """A two-way lane 30 km long: the radius it bounds (about the lane) would subscribe
    each AGV to millions of cells; the fleet has every node hear every node instead."""
    far = 30_000.0
    points = [Point("w", 0, 0), Point("e", far, 0)]
    points += [Point(p, x, y) for p, x, y in (("wp", 0, 5), ("ws", 0, -5))]
    points += [Point(p, far, y) for p, y in (("ep", 5), ("es", -5))]
    segments = [
        Segment(f"{a}-{b}", a, b, bidirectional=True)
        for a, b in (("w", "e"), ("w", "wp"), ("w", "ws"), ("e", "ep"), ("e", "es"))
    ]
    stations = [
        Station("park-w", "wp", "parking"),
        Station("park-e", "ep", "parking"),
        Station("dock-w", "ws", "pickdrop"),
        Station("dock-e", "es", "pickdrop"),
    ]
    layout = Layout(points, segments, stations, name="long-lane")
    assert interest_radius(layout, SPEC, AgvConfig()) > far
    fleet = Fleet(layout, FleetConfig(agvs=2, seed=1, start_tasks=1, load=0.5))
    assert fleet.interest_radius is None
    assert fleet.footprint_margin is None
    fleet.run(20.0)
    assert fleet.summary()["collisions"] == fleet.summary()["lock_overlaps"] == 0
    assert {n for agv in fleet.agvs.values() for n in agv.node.view()} >= set(fleet.agvs)
