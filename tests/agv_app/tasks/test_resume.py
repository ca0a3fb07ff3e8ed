"""A task desk on an order store, crashed and started again on what the store kept:
every open task is back, none is carried twice, and a vehicle that holds one finishes
it or hands it back."""

from __future__ import annotations

import contextlib
import functools
import random
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.mesh import MeshFleet
from agv_app.layout.demo import demo_warehouse
from agv_app.tasks.book import TaskRecord
from agv_app.tasks.desk import TaskDesk
from agv_app.tasks.store import OrderStore
from objectplaces.sim import SimulatedNetwork
from tests.agv_app.tasks.fake_agvs import FakeAgv

LAYOUT = demo_warehouse()
STATIONS = ("dock-in-1", "dock-in-2")
GRACE = 20.0


@dataclass
class Control:
    """A desk on a store, its stations on nodes of their own, as a control runs them."""

    net: SimulatedNetwork
    store: OrderStore
    desk: TaskDesk
    nodes: list[str] = field(default_factory=list)

    @classmethod
    def start(
        cls, net: SimulatedNetwork, path: Path, *, wall: Callable[[], float] = time.time, **kw
    ) -> Control:
        store = OrderStore.open(path, wall=wall)
        desk = TaskDesk(
            LAYOUT,
            rng=random.Random(1),
            clock=lambda: net.now,
            store=store,
            hand_back_after=GRACE,
            **kw,
        )
        control = cls(net, store, desk)
        for sid in STATIONS:
            control.nodes.append(f"st:{sid}")
            desk.open_station(sid, net.add_node(f"st:{sid}"))
        return control

    def crash(self, image: Path) -> Path:
        """SIGKILL: the nodes stop without a word; the files are as the last commit left
        them (copied to ``image``, with the write-ahead log). The image's path."""
        for node_id in self.nodes:
            self.net.remove_node(node_id)
        return crash_image(self.store, image)


def crash_image(store: OrderStore, image: Path) -> Path:
    """The store's files as they are now, copied to ``image``: what a killed process leaves."""
    shutil.copyfile(store.path, image)
    wal = store.path.with_name(store.path.name + "-wal")
    if wal.exists():
        shutil.copyfile(wal, image.with_name(image.name + "-wal"))
    return image


def fleet(net: SimulatedNetwork, n: int = 3) -> list[FakeAgv]:
    spots = [(9.75, 1.5), (34.75, 1.5), (20.0, 1.5)]
    return [FakeAgv(net.add_node(f"agv-{i + 1}"), spots[i % 3]) for i in range(n)]


def holders(agvs: list[FakeAgv]) -> dict[str, str]:
    return {t.id: a.node_id for a in agvs for t in a.held}


def record(desk: TaskDesk, task_id: str) -> TaskRecord:
    found = desk.book.get(task_id)
    assert found is not None, task_id
    return found


def open_tasks(desk: TaskDesk) -> list[tuple[str, str, str | None]]:
    return [(r.id, r.state, r.vehicle) for r in desk.book.records() if r.id in desk.book.open_ids()]


def test_a_restarted_desk_resumes_every_open_task_and_carries_none_twice(tmp_path: Path) -> None:
    net = SimulatedNetwork(seed=3)
    agvs = fleet(net, 2)
    control = Control.start(net, tmp_path / "orders.db")
    ids = [control.desk.create("dock-in-1", "dock-out-1") for _ in range(4)]
    assert net.run_until(lambda: len(holders(agvs)) == 2, timeout=60.0)
    first = holders(agvs)
    assert sorted(first) == ids[:2]
    before = open_tasks(control.desk)
    assert [t[0] for t in before] == ids

    agvs[0].deliver()  # the control dies before it hears of it
    image = control.crash(tmp_path / "image.db")
    again = Control.start(net, image)
    assert open_tasks(again.desk) == before
    station = again.desk.stations["dock-in-1"]
    assert station.assigned == {i: (record(again.desk, i).task, agv) for i, agv in first.items()}
    assert [t.id for t in station.queue] == ids[2:]

    # The free vehicle takes the next ones; the one that holds a task keeps it.
    for _ in range(len(ids) * 2):
        for agv in agvs:
            if agv.held:
                agv.deliver()
        net.run_for(10.0)
    assert again.desk.book.open_ids() == []
    delivered = [t for a in agvs for t in a.delivered]
    assert sorted(delivered) == sorted(ids)  # each once
    assert again.desk.book.double_assignments == 0
    control.store.close()
    again.store.close()


def test_a_task_reported_done_while_the_control_was_down_is_closed_on_restart(
    tmp_path: Path,
) -> None:
    net = SimulatedNetwork(seed=4)
    (agv,) = fleet(net, 1)
    control = Control.start(net, tmp_path / "orders.db")
    task_id = control.desk.create("dock-in-1", "dock-out-1")
    assert net.run_until(lambda: bool(agv.held), timeout=30.0)
    image = control.crash(tmp_path / "image.db")
    agv.deliver()  # while no control listens
    net.run_for(2.0)
    again = Control.start(net, image)
    assert record(again.desk, task_id).state == "assigned"
    assert net.run_until(lambda: again.desk.book.open_ids() == [], timeout=10.0)
    assert record(again.desk, task_id).state == "done"
    assert agv.delivered == [task_id]
    control.store.close()
    again.store.close()


@pytest.mark.parametrize("how", ["returned", "forgot", "gone"])
def test_a_vehicle_that_no_longer_holds_its_task_hands_it_back_to_another(
    tmp_path: Path, how: str
) -> None:
    net = SimulatedNetwork(seed=5)
    agvs = fleet(net, 2)
    control = Control.start(net, tmp_path / "orders.db")
    task_id = control.desk.create("dock-in-1", "dock-out-1")
    assert net.run_until(lambda: bool(holders(agvs)), timeout=30.0)
    first = next(a for a in agvs if a.held)
    other = next(a for a in agvs if a is not first)
    image = control.crash(tmp_path / "image.db")
    if how == "gone":
        net.remove_node(first.node_id)  # gone for good while the control was down
    start = net.now
    again = Control.start(net, image)
    net.run_for(1.0)
    if how == "returned":
        first.hand_back()
    elif how == "forgot":
        first.forget()  # its process restarted
    first.held.clear()
    if how != "gone":
        first.node.update_node_property("status", "off")  # it bids no more
    assert net.run_until(lambda: task_id in [t.id for t in other.held], timeout=3 * GRACE)
    waited = net.now - start
    assert waited < GRACE if how == "returned" else waited >= GRACE
    held = record(again.desk, task_id)
    assert (held.state, held.vehicle) == ("assigned", other.node_id)
    assert again.desk.book.double_assignments == 0
    assert again.desk.returned == 1
    control.store.close()
    again.store.close()


# -- any sequence of desk operations, a crash at any commit, and a restore --------------------

_create = st.tuples(st.just("create"), st.sampled_from(STATIONS), st.sampled_from(["auto", "api"]))
_run = st.tuples(st.just("run"), st.floats(1.0, 8.0), st.none())
_ops = st.lists(
    st.one_of(
        _create,
        _create,
        _run,
        _run,
        st.tuples(st.just("run"), st.floats(0.01, 0.5), st.none()),
        st.tuples(st.just("cancel"), st.integers(0, 30), st.none()),
        st.tuples(st.sampled_from(["deliver", "hand_back", "start"]), st.integers(0, 2), st.none()),
    ),
    min_size=5,
    max_size=30,
)


def _snapshot(desk: TaskDesk, at: float) -> list[tuple[object, ...]]:
    """The open tasks as a restore must give them back, times counted from ``at``."""
    return [
        (r.id, r.task.pick, r.task.drop, r.state, r.vehicle, r.creator,
         {s: pytest.approx(t - at, abs=1e-6) for s, t in r.times.items()})
        for r in desk.book.records()
        if r.id in desk.book.open_ids()
    ]  # fmt: skip


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_ops, st.sets(st.integers(0, 25), max_size=4), st.sampled_from([None, 2]))
def test_a_crash_after_any_commit_restores_the_same_open_orders(ops, crash_at, max_open) -> None:
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        net = SimulatedNetwork(seed=7)
        agvs = fleet(net, 3)
        control = Control.start(
            net, tmp / "orders.db", wall=lambda: 5000.0 + net.now, max_open=max_open
        )
        desk = control.desk
        images: list[tuple[Path, float, list[tuple[object, ...]]]] = []
        for step, (kind, arg, creator) in enumerate([*ops, ("run", 0.0, None)]):
            if kind == "create":
                desk.create(arg, creator=creator)
            elif kind == "cancel":
                open_ids = desk.book.open_ids()
                if open_ids:
                    with contextlib.suppress(ValueError):  # held by a vehicle: refused
                        desk.cancel(open_ids[arg % len(open_ids)])
            elif kind == "run":
                net.run_for(arg)
            else:
                agv = agvs[arg]
                if not agv.held:
                    continue
                if kind == "deliver":
                    agv.deliver()
                elif kind == "hand_back":
                    agv.hand_back()
                else:
                    desk.book.start(agv.held[0].id, agv.node_id, now=net.now)
            if step in crash_at or step == len(ops):
                image = crash_image(control.store, tmp / f"image-{step}.db")
                images.append((image, net.now, _snapshot(desk, net.now)))
        control.store.close()

        for image, at, expected in images:
            fresh = SimulatedNetwork(seed=8)
            restored = Control.start(fresh, image, wall=functools.partial(float, 5000.0 + at))
            assert _snapshot(restored.desk, 0.0) == expected
            rdesk = restored.desk
            records = [record(rdesk, i) for i in rdesk.book.open_ids()]
            held = {r.id: r.vehicle for r in records if r.state in ("assigned", "driving")}
            at_stations = {
                task_id: agv
                for s in rdesk.stations.values()
                for task_id, (_, agv) in s.assigned.items()
            }
            assert at_stations == held
            for sid, station in rdesk.stations.items():  # back in line, oldest first
                unheld = [
                    i for i in rdesk.book.open_ids()
                    if i not in held and record(rdesk, i).task.pick == sid
                ]  # fmt: skip
                assert [t.id for t in station.queue] == unheld
            restored.store.close()


def test_the_fleets_take_back_the_open_tasks_of_their_store(tmp_path: Path) -> None:
    net = SimulatedNetwork(seed=9)
    control = Control.start(net, tmp_path / "orders.db")
    ids = [control.desk.create("dock-in-1", "dock-out-1") for _ in range(3)]
    control.desk.cancel(ids[1])
    control.store.close()
    with OrderStore.open(tmp_path / "orders.db") as store:
        mesh = MeshFleet(agvs=2, store=store)
        assert mesh.open_tasks == [ids[0], ids[2]]
        assert [r.state for r in mesh.task_records()] == ["cancelled", "created", "created"]
    with OrderStore.open(tmp_path / "orders.db") as store:
        sim = Fleet(LAYOUT, FleetConfig(agvs=2, seed=1, task_interval=1e9), store=store)
        assert sim.open_tasks == [ids[0], ids[2]]
        assert [t.id for t in sim.stations["dock-in-1"].queue] == [ids[0], ids[2]]
        assert sim.create_task("dock-in-2") == "task-4"
