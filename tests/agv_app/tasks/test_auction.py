"""Task assignment: best bid wins, late joiners bid, never twice, returned on failure."""

from __future__ import annotations

from typing import Any

from agv_app.tasks import Bidder, TaskSpec
from agv_app.tasks.station import Station
from objectplaces import RoleActivator
from objectplaces.sim import SimulatedNetwork


class Agent:
    """A fake AGV: bids a fixed cost while idle; publishes what the fleet's AGV does.

    With ``arrives`` it reaches the pick station as it takes a task (``reached_pick``);
    without, only when told (:meth:`arrive`).
    """

    def __init__(self, node: RoleActivator, x: float, cost: float, *, arrives: bool = True) -> None:
        self.node = node
        self.cost = cost
        self.arrives = arrives
        self.taken: list[TaskSpec] = []
        node.update_node_property("kind", "agv")
        node.update_node_property("status", "idle")
        node.update_node_property("position", (x, 0.0))
        node.set_participant_factory("bidder", lambda: Bidder(self))

    def bid_for(self, task: TaskSpec) -> float | None:
        return None if self.taken else self.cost

    def take(self, task: TaskSpec) -> None:
        self.taken.append(task)
        self.node.update_node_property("status", "busy")
        self.node.update_node_property("task", task.id)
        if self.arrives:
            self.arrive()

    def arrive(self) -> None:
        self.node.update_node_property("reached_pick", self.taken[-1].id)

    def finish(self) -> None:
        self.node.update_node_property("last_done", self.taken[-1].id)
        self.node.update_node_property("status", "idle")


def add_station(
    net: SimulatedNetwork, name: str, x: float, **options: Any
) -> tuple[Station, list[TaskSpec]]:
    """A station on a node of its own at ``(x, 0)``, auctioning within 20 m; the tasks it
    awarded, in order."""
    awarded: list[TaskSpec] = []
    station = Station(
        net.add_node(name),
        name,
        (x, 0.0),
        range_m=20.0,
        on_assigned=lambda t, a: awarded.append(t),
        **options,
    )
    return station, awarded


def setup(
    seed: int = 1, *, one_at_a_time: bool = True, wait_for_drop: bool = True, **kw: Any
) -> tuple[SimulatedNetwork, Station, list[TaskSpec]]:
    net = SimulatedNetwork(seed=seed, property_interval=0.5, **kw)
    station, awarded = add_station(
        net, "st", 0.0, one_at_a_time=one_at_a_time, wait_for_drop=wait_for_drop
    )
    return net, station, awarded


def _won_by_first(net: SimulatedNetwork, station: Station, task_id: str) -> Agent:
    """An AGV "first" that wins ``task_id``, the station's only task so far."""
    first = Agent(net.add_node("first"), 1.0, 1.0)
    net.run_for(0.5)
    station.add_task(TaskSpec(task_id, "st", "x"))
    net.run_for(4.0)
    assert [t.id for t in first.taken] == [task_id]
    return first


def test_best_bid_wins_and_the_task_is_given_once() -> None:
    net, station, awarded = setup()
    far = Agent(net.add_node("far"), 15.0, 15.0)
    near = Agent(net.add_node("near"), 5.0, 5.0)
    out = Agent(net.add_node("out"), 50.0, 1.0)  # out of range: never asked
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    net.run_for(5.0)
    assert [t.id for t in near.taken] == ["t1"]
    assert far.taken == out.taken == []
    assert awarded == [TaskSpec("t1", "st", "x")]
    assert station.assigned == {"t1": (TaskSpec("t1", "st", "x"), "near")}
    near.finish()
    net.run_for(1.0)
    assert station.assigned == {}


def test_an_agv_that_enters_range_during_the_session_may_bid() -> None:
    net, station, _ = setup()
    station.add_task(TaskSpec("t1", "st", "x"))
    late = Agent(net.add_node("late"), 40.0, 3.0)
    net.run_for(3.0)
    assert late.taken == []
    late.node.update_node_property("position", (10.0, 0.0))
    net.run_for(3.0)
    assert [t.id for t in late.taken] == ["t1"]


def test_a_bidder_waiting_for_its_agvs_bid_elsewhere_sleeps_until_that_bid_ends() -> None:
    net, here, _ = setup()  # station "st" at x = 0
    there, there_awarded = add_station(net, "st2", 30.0)
    best = Agent(net.add_node("best"), 1.0, 1.0)  # in range of "st" only
    both = Agent(net.add_node("both"), 15.0, 5.0)  # in range of both
    net.run_for(0.5)
    here.add_task(TaskSpec("t-here", "st", "x"))
    net.run_for(0.3)  # "both" bids here first
    there.add_task(TaskSpec("t-there", "st2", "x"))
    net.run_for(0.5)
    assert both.taken == []
    # Its bidder for "st2" waits without a timer: it asks nothing until the bid ends.
    assert both.node.machine.footprint()["role_timers"] == 0
    net.run_for(1.0)  # the window closes: "best" wins here, "both" bids there
    assert [t.id for t in best.taken] == ["t-here"]
    net.run_for(2.5)
    assert [t.id for t in both.taken] == ["t-there"] == [t.id for t in there_awarded]


def test_tasks_queue_and_each_goes_to_one_agv_under_loss() -> None:
    # At 10% loss three republications in a row go missing about once in a thousand
    # intervals, so now and then the station counts a live winner as failed (seed 5
    # does, at 6.5 s); the winner, heard again carrying its task, keeps it.
    net, station, awarded = setup(seed=5, loss=0.1, delay=0.02, jitter=0.01)
    agents = [Agent(net.add_node(f"a{i}"), float(i), float(i)) for i in range(4)]
    for k in range(3):
        station.add_task(TaskSpec(f"t{k}", "st", "x"))
    net.run_for(30.0)
    taken = [t.id for a in agents for t in a.taken]
    assert sorted(taken) == ["t0", "t1", "t2"]
    assert all(len(a.taken) <= 1 for a in agents)
    assert len(awarded) == 3


def test_a_task_whose_agv_fails_is_returned_and_given_again() -> None:
    net, station, awarded = setup()
    _won_by_first(net, station, "t1")
    net.remove_node("first")
    second = Agent(net.add_node("second"), 2.0, 2.0)
    net.run_for(6.0)  # failure timeout 1.5 s, then return_after 5 s
    assert station.returned == 0
    assert second.taken == []
    net.run_for(4.0)
    assert station.returned == 1
    assert [t.id for t in second.taken] == ["t1"]
    assert [t.id for t in awarded] == ["t1", "t1"]


def test_a_winner_counted_as_failed_and_heard_again_keeps_its_task() -> None:
    net, station, awarded = setup()
    first = Agent(net.add_node("first"), 1.0, 1.0)
    second = Agent(net.add_node("second"), 2.0, 2.0)
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    net.run_for(4.0)
    assert [t.id for t in first.taken] == ["t1"]
    second.node.update_node_property("status", "idle")
    net.partition(["st"], ["first", "second"])
    net.run_for(2.5)  # the station counts "first" as failed
    assert "first" not in station.node.view()
    net.heal()
    net.run_for(8.0)
    assert station.returned == 0
    assert second.taken == []
    assert [t.id for t in awarded] == ["t1"]
    assert station.assigned == {"t1": (TaskSpec("t1", "st", "x"), "first")}


def test_a_winner_that_restarts_without_its_task_has_it_returned() -> None:
    net, station, awarded = setup()
    _won_by_first(net, station, "t1")
    net.remove_node("first")
    net.run_for(2.0)
    Agent(net.add_node("first"), 1.0, 5.0)  # back within return_after, the task forgotten
    net.run_for(8.0)
    assert station.returned == 1
    assert [t.id for t in awarded] == ["t1", "t1"]


def test_a_task_returned_during_another_auction_does_not_requeue_the_one_awarded() -> None:
    net, station, awarded = setup()
    _won_by_first(net, station, "t0")
    station.add_task(TaskSpec("t1", "st", "x"))  # nobody idle: its auction waits
    net.remove_node("first")
    net.run_for(8.0)  # t0 comes back, in front of t1, while t1's auction runs
    assert station.returned == 1
    assert station.current == TaskSpec("t1", "st", "x")
    Agent(net.add_node("second"), 2.0, 2.0)
    net.run_for(4.0)
    assert [t.id for t in awarded] == ["t0", "t1"]
    assert [t.id for t in station.queue] == ["t0"]
    Agent(net.add_node("third"), 3.0, 3.0)
    Agent(net.add_node("fourth"), 4.0, 4.0)
    net.run_for(10.0)
    assert [t.id for t in awarded] == ["t0", "t1", "t0"]
    assert list(station.queue) == []


def _counted_as_failed_then_heard(net: SimulatedNetwork, first: Agent) -> None:
    """Cut ``first`` off from the station until it counts it as failed, then heal."""
    net.partition(["st"], [first.node.node_id])
    net.run_for(2.5)
    net.heal()


def test_a_winner_heard_again_with_its_next_task_has_time_to_report_this_one() -> None:
    net, station, awarded = setup()
    first = _won_by_first(net, station, "t1")
    _counted_as_failed_then_heard(net, first)
    first.node.update_node_property("task", "t9")  # taken while dwelling at t1's drop
    net.run_for(6.0)
    assert station.returned == 0
    first.finish()  # t1 reported done as the dwell ends
    net.run_for(8.0)
    assert station.returned == 0
    assert station.assigned == {}
    assert [t.id for t in awarded] == ["t1"]


def test_a_winner_heard_again_with_another_task_that_never_reports_this_one_returns_it() -> None:
    net, station, _ = setup()
    first = _won_by_first(net, station, "t1")
    _counted_as_failed_then_heard(net, first)
    first.node.update_node_property("task", "t9")
    net.run_for(6.0)
    assert station.returned == 0
    net.run_for(5.0)
    assert station.returned == 1
    assert [t.id for t in station.queue] == ["t1"]


def _two_tasks_for_two_slow_agvs(
    one_at_a_time: bool,
) -> tuple[SimulatedNetwork, Station, Agent, Agent]:
    net, station, _ = setup(one_at_a_time=one_at_a_time)
    near = Agent(net.add_node("near"), 1.0, 1.0, arrives=False)
    far = Agent(net.add_node("far"), 9.0, 9.0, arrives=False)
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    station.add_task(TaskSpec("t2", "st", "x"))
    net.run_for(10.0)
    return net, station, near, far


def test_a_station_calls_the_next_agv_once_the_last_one_reached_it() -> None:
    net, station, near, far = _two_tasks_for_two_slow_agvs(one_at_a_time=True)
    assert [t.id for t in near.taken] == ["t1"]
    assert far.taken == []
    assert station.approaching == ("near",)
    near.arrive()
    net.run_for(5.0)
    assert [t.id for t in far.taken] == ["t2"]
    assert station.approaching == ("far",)
    far.arrive()
    net.run_for(1.0)
    assert not station.approaching


def test_a_station_not_one_at_a_time_sends_both_at_once() -> None:
    _, station, near, far = _two_tasks_for_two_slow_agvs(one_at_a_time=False)
    assert [t.id for t in near.taken + far.taken] == ["t1", "t2"]
    assert station.approaching == ("near", "far")


def test_a_winner_done_without_saying_it_arrived_lets_the_next_one_come() -> None:
    net, _, near, far = _two_tasks_for_two_slow_agvs(one_at_a_time=True)
    near.finish()
    net.run_for(5.0)
    assert [t.id for t in far.taken] == ["t2"]


def test_a_winner_that_fails_on_its_way_does_not_hold_the_station_up() -> None:
    net, station, _, far = _two_tasks_for_two_slow_agvs(one_at_a_time=True)
    net.remove_node("near")
    net.run_for(12.0)  # failure timeout, return_after; t1 goes back first in line
    assert station.returned == 1
    assert [t.id for t in far.taken] == ["t1"]
    far.arrive()
    late = Agent(net.add_node("late"), 3.0, 3.0)
    net.run_for(5.0)
    assert [t.id for t in late.taken] == ["t2"]


def _carrier(net: SimulatedNetwork, drop: str) -> RoleActivator:
    """An AGV node carrying a load to station ``drop`` (``dropping_at``)."""
    carrier = net.add_node("carrier")
    carrier.update_node_property("kind", "agv")
    carrier.update_node_property("dropping_at", drop)
    return carrier


def _a_task_and_a_carrier_bound_here(
    held_for: float,
) -> tuple[SimulatedNetwork, Station, RoleActivator, Agent]:
    """A station with a task, an idle AGV, and an AGV carrying another station's task
    here (``dropping_at``); run for ``held_for`` seconds after the task appears."""
    net, station, _ = setup()
    carrier = _carrier(net, "st")
    idle = Agent(net.add_node("idle"), 1.0, 1.0)
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    net.run_for(held_for)
    return net, station, carrier, idle


def test_a_station_waits_for_an_agv_bound_to_drop_there() -> None:
    net, station, carrier, idle = _a_task_and_a_carrier_bound_here(5.0)
    assert idle.taken == []
    assert station.approaching == ("carrier",)
    carrier.update_node_property("dropping_at", None)
    net.run_for(5.0)
    assert [t.id for t in idle.taken] == ["t1"]


def test_an_agv_bound_to_drop_there_that_fails_does_not_hold_the_station_up() -> None:
    net, station, _, idle = _a_task_and_a_carrier_bound_here(2.0)
    assert idle.taken == []
    net.remove_node("carrier")
    net.run_for(5.0)  # failure timeout 1.5 s: gone from the view, and from the way here
    assert not station.approaching
    assert [t.id for t in idle.taken] == ["t1"]


def _a_task_to_a_drop_another_agv_is_bound_for(
    wait_for_drop: bool, bound_for: str = "x"
) -> tuple[SimulatedNetwork, RoleActivator, Agent]:
    """A station with a task to drop station "x", an idle AGV, and an AGV carrying
    another station's load to ``bound_for``; 5 s after the task appears."""
    net, station, _ = setup(wait_for_drop=wait_for_drop)
    carrier = _carrier(net, bound_for)
    idle = Agent(net.add_node("idle"), 1.0, 1.0)
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    net.run_for(5.0)
    return net, carrier, idle


def test_a_station_holds_a_task_whose_drop_station_another_agv_is_bound_for() -> None:
    """Found on the generated warehouse for 100 AGVs (seed 1, 30 minutes): three AGVs
    bound to drop at one station, sent by three stations, queued in its aisle back onto
    the lanes, and the floor locked (50 waits over 180 s)."""
    net, carrier, idle = _a_task_to_a_drop_another_agv_is_bound_for(wait_for_drop=True)
    assert idle.taken == []
    carrier.update_node_property("dropping_at", None)  # it arrived
    net.run_for(5.0)
    assert [t.id for t in idle.taken] == ["t1"]


def test_without_the_rule_the_task_goes_at_once() -> None:
    _, _, idle = _a_task_to_a_drop_another_agv_is_bound_for(wait_for_drop=False)
    assert [t.id for t in idle.taken] == ["t1"]


def test_an_agv_bound_for_another_drop_station_holds_nothing() -> None:
    _, _, idle = _a_task_to_a_drop_another_agv_is_bound_for(wait_for_drop=True, bound_for="y")
    assert [t.id for t in idle.taken] == ["t1"]


def test_a_task_held_for_its_drop_station_holds_the_newer_ones_too() -> None:
    """The station's next task is its oldest: auctioning newer tasks around a busy
    drop station sent more AGVs onto full lanes, and the generated warehouse for 100
    AGVs locked again (seed 1, 30 minutes: 47 waits over 180 s)."""
    net, station, _ = setup()
    carrier = _carrier(net, "x")
    first = Agent(net.add_node("first"), 1.0, 1.0)
    net.run_for(0.5)
    station.add_task(TaskSpec("t1", "st", "x"))
    station.add_task(TaskSpec("t2", "st", "y"))
    net.run_for(5.0)
    assert first.taken == []
    carrier.update_node_property("dropping_at", None)
    net.run_for(5.0)
    assert [t.id for t in first.taken] == ["t1"]
