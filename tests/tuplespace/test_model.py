"""The space against a naive model: a list scanned oldest first."""

from __future__ import annotations

import operator
from typing import Any

from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, rule

from tuplespace import ANY, TupleSpace

Entry = tuple[Any, ...]

# Values chosen to hit the edges: equal across types (1, 1.0, True), unhashable (a list,
# a set), and a set equal to a hashable frozenset.
VALUES: list[Any] = [0, 1, 1.0, True, "a", [1]]


def is_even(value: object) -> bool:
    return isinstance(value, int) and value % 2 == 0


FORMALS: list[Any] = [ANY, str, set, is_even]

# First fields come from a small pool so that tags collide often, the unhashable ones
# included: that is where the index and the FIFO merge with unkeyed tuples can go wrong.
FIRSTS: list[Any] = ["a", {1}, frozenset({1})]

values = st.sampled_from(VALUES)
rest = st.lists(values, max_size=1)
entries = st.builds(lambda f, r: (f, *r), st.sampled_from(FIRSTS), rest)
template_fields = st.sampled_from(VALUES + FORMALS)
templates = st.just(()) | st.builds(
    lambda f, r: (f, *r),
    st.sampled_from(FIRSTS + FORMALS),
    st.lists(template_fields, max_size=1),
)
leases = st.none() | st.sampled_from([0.0, 0.5, 1.0, 2.0])


def field_matches(field: Any, value: Any) -> bool:
    if field is ANY:
        return True
    if isinstance(field, type):
        return isinstance(value, field)
    if callable(field):
        return bool(field(value))
    return field is value or bool(field == value)


def model_matches(template: Entry, entry: Entry) -> bool:
    return len(template) == len(entry) and all(map(field_matches, template, entry))


def same(got: list[Entry], expected: list[Entry]) -> bool:
    # Identity, not equality: {1} == frozenset({1}), so only identity shows which of
    # two equal tuples came back, and FIFO is about which one.
    return len(got) == len(expected) and all(map(operator.is_, got, expected))


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class SpaceMatchesModel(RuleBasedStateMachine):
    """Every operation gives what a list scanned oldest first would give."""

    @initialize()
    def start(self) -> None:
        self.clock = Clock()
        self.space = TupleSpace(clock=self.clock)
        self.model: list[tuple[Entry, float]] = []  # (tuple, lease end), oldest first

    def drop_ended(self) -> int:
        live = [(e, end) for e, end in self.model if end > self.clock.now]
        dropped = len(self.model) - len(live)
        self.model = live
        return dropped

    def first(self, template: Entry) -> int | None:
        return next((i for i, (e, _) in enumerate(self.model) if model_matches(template, e)), None)

    @rule(entry=entries, lease=leases)
    def out(self, entry: Entry, lease: float | None) -> None:
        self.space.out(entry, lease=lease)
        self.drop_ended()
        end = float("inf") if lease is None else self.clock.now + lease
        if end > self.clock.now:
            self.model.append((entry, end))

    @rule(batch=st.lists(entries, min_size=2, max_size=6))
    def out_many(self, batch: list[Entry]) -> None:
        # Writes outnumber takes, or the space is empty most of the time.
        for entry in batch:
            self.out(entry, None)

    @rule(template=templates)
    def inp(self, template: Entry) -> None:
        got = self.space.inp(template)
        self.drop_ended()
        i = self.first(template)
        if i is None:
            assert got is None
        else:
            assert got is self.model.pop(i)[0]

    @rule(template=templates)
    def rdp(self, template: Entry) -> None:
        got = self.space.rdp(template)
        self.drop_ended()
        i = self.first(template)
        assert got is (None if i is None else self.model[i][0])

    @rule(template=templates)
    def rd_all_and_count(self, template: Entry) -> None:
        got = self.space.rd_all(template)
        self.drop_ended()
        expected = [e for e, _ in self.model if model_matches(template, e)]
        assert same(got, expected)
        assert self.space.count(template) == len(expected)

    @rule(template=templates)
    def in_all(self, template: Entry) -> None:
        got = self.space.in_all(template)
        self.drop_ended()
        assert same(got, [e for e, _ in self.model if model_matches(template, e)])
        self.model = [(e, end) for e, end in self.model if not model_matches(template, e)]

    @rule(dt=st.sampled_from([0.25, 0.5, 1.0]))
    def advance(self, dt: float) -> None:
        self.clock.now += dt

    @rule()
    def expire(self) -> None:
        assert self.space.expire() == self.drop_ended()

    @invariant()
    def next_expiry_is_the_earliest_stored_end(self) -> None:
        ends = [end for _, end in self.model if end != float("inf")]
        assert self.space.next_expiry() == (min(ends) if ends else None)

    @invariant()
    def same_size(self) -> None:
        size = len(self.space)  # drops ended leases, as every operation does
        self.drop_ended()
        assert size == len(self.model)


SpaceMatchesModel.TestCase.settings = settings(
    max_examples=100, stateful_step_count=50, deadline=None
)
TestSpaceMatchesModel = SpaceMatchesModel.TestCase
