"""The cell router alone: who hears a publication, who syncs a new subscriber, and that
its tables shrink back when nodes go."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from objectplaces.transport.routing import Cell, CellRouter, Subscribed


def cells(*pairs: Cell) -> frozenset[Cell]:
    return frozenset(pairs)


def test_a_publication_reaches_full_subscribers_and_those_of_its_cells() -> None:
    router = CellRouter()
    router.subscribe("full", None)
    router.subscribe("here", cells((0, 0), (0, 1)))
    router.subscribe("left", cells((5, 5)))
    router.subscribe("far", cells((9, 9)))
    assert list(router.publish("p", [(0, 0)])) == ["full", "here"]
    # moving from (5, 5) to (0, 1): the cell it left hears it too
    assert list(router.publish("p", [(0, 1), (5, 5)])) == ["full", "here", "left"]
    # never to itself
    assert list(router.publish("here", [(0, 0)])) == ["full"]


def test_a_new_subscriber_is_synced_by_the_publishers_of_its_new_cells() -> None:
    router = CellRouter()
    router.publish("a", [(0, 0)])
    router.publish("b", [(1, 0)])
    router.publish("c", [(7, 7)])
    router.publish("a", [(2, 0), (0, 0)])  # a moved on: (0, 0) has no publisher now
    assert router.subscribe("s", cells((0, 0), (1, 0), (2, 0))) == Subscribed(False, ("b", "a"))
    # only the cells it newly covers count
    assert router.subscribe("s", cells((1, 0), (2, 0), (7, 7))) == Subscribed(False, ("c",))
    assert router.subscribe("c", cells((7, 7))) == Subscribed(False, ())  # not itself


def test_a_full_subscription_is_news_only_the_first_time() -> None:
    router = CellRouter()
    assert router.subscribe("n", None) == Subscribed(True, ())
    assert router.subscribe("n", None) == Subscribed(False, ())
    router.subscribe("n", cells((0, 0)))
    assert router.subscribe("n", None) == Subscribed(True, ())
    assert list(router.publish("p", [(3, 3)])) == ["n"]


def test_a_subscriber_that_stays_in_a_cell_keeps_its_place() -> None:
    router = CellRouter()
    router.subscribe("a", cells((0, 0)))
    router.subscribe("b", cells((0, 0)))
    router.subscribe("a", cells((0, 0), (0, 1)))  # a widens; it was first in (0, 0)
    assert list(router.publish("p", [(0, 0)])) == ["a", "b"]


def test_forgotten_nodes_leave_nothing_behind() -> None:
    router = CellRouter()
    router.subscribe("a", cells((0, 0), (1, 1)))
    router.subscribe("b", None)
    router.publish("a", [(0, 0)])
    router.unsubscribe("b")
    assert list(router.publish("p", [(0, 0)])) == ["a"]
    router.forget("a")
    router.forget("p")
    assert len(router) == 0
    assert router.home("a") == ()
    assert router._cell_subs == {}
    assert router._publishers_in == {}


node_ids = st.sampled_from(["a", "b", "c", "d"])
some_cells = st.frozensets(st.tuples(st.integers(0, 3), st.integers(0, 3)), max_size=5)
actions = st.lists(
    st.one_of(
        st.tuples(st.just("subscribe"), node_ids, st.none() | some_cells),
        st.tuples(st.just("publish"), node_ids, st.lists(st.tuples(st.integers(0, 3),
                                                                     st.integers(0, 3)),
                                                           min_size=1, max_size=2)),
        st.tuples(st.just("forget"), node_ids, st.none()),
    ),
    max_size=40,
)  # fmt: skip


@settings(max_examples=200)
@given(actions)
def test_the_router_agrees_with_a_plain_model(steps: list[tuple[str, str, object]]) -> None:
    router = CellRouter()
    subs: dict[str, frozenset[Cell] | None] = {}
    last: dict[str, Cell] = {}
    for action, node, arg in steps:
        if action == "subscribe":
            assert arg is None or isinstance(arg, frozenset)
            old = subs.get(node, frozenset())
            result = router.subscribe(node, arg)
            subs[node] = arg
            if arg is not None:
                newly = arg - (old or frozenset())
                expected = {n for n, c in last.items() if c in newly and n != node}
                assert set(result.publishers) == expected
        elif action == "publish":
            assert isinstance(arg, list)
            targets = router.publish(node, arg)
            last[node] = arg[0]
            expected = {n for n, s in subs.items() if n != node and (s is None or s & set(arg))}
            assert set(targets) == expected
        else:
            router.forget(node)
            subs.pop(node, None)
            last.pop(node, None)
    assert len(router) == len(subs.keys() | last.keys())
    for cell, subscribers in router._cell_subs.items():
        assert subscribers, f"empty entry for {cell}"
