"""``TupleSpace.version``: unchanged exactly while the tuples of its key are."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tuplespace import ANY, TupleSpace


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


OPS = st.lists(
    st.tuples(
        st.sampled_from(["out", "out_leased", "inp", "in_all", "rdp", "wait", "other"]),
        st.sampled_from(["lock", "request"]),
        st.integers(0, 2),
    ),
    max_size=60,
)


@given(ops=OPS)
def test_a_version_seen_again_means_the_same_tuples(ops: list[tuple[str, str, int]]) -> None:
    clock = Clock()
    space = TupleSpace(clock=clock)
    seen: dict[tuple[str, int], list[tuple[Any, ...]]] = {}
    for what, key, n in ops:
        version_before = space.version(key)
        moved = True  # the op stores or removes a tuple of ``key``
        if what == "out":
            space.out((key, n))
        elif what == "out_leased":
            space.out((key, n), lease=0.5)
        elif what == "inp":
            moved = space.inp((key, n)) is not None
        elif what == "in_all":
            moved = bool(space.in_all((key, ANY)))
        elif what == "rdp":
            space.rdp((key, n))
            moved = False
        elif what == "wait":
            clock.now += 0.3 * n
            moved = False
        else:
            space.out(("other", n))  # another key's tuple
            moved = False
        if what != "wait":
            assert (space.version(key) != version_before) is moved
        for k in ("lock", "request"):
            tuples = space.rd_all((k, ANY))
            # The plain path: compare the tuples themselves.
            assert seen.setdefault((k, space.version(k)), tuples) == tuples


def test_every_store_and_removal_moves_the_version_and_reads_do_not() -> None:
    clock = Clock()
    space = TupleSpace(clock=clock)
    assert space.version("lock") == 0
    space.out(("lock", 1))
    stored = space.version("lock")
    assert stored != 0
    space.rdp(("lock", ANY))
    space.rd_all(("lock", ANY))
    space.out(("request", 1))
    assert space.version("lock") == stored
    space.out(("lock", 1))  # an equal tuple is still another one
    again = space.version("lock")
    assert again not in (0, stored)
    space.inp(("lock", 1))
    taken = space.version("lock")
    assert taken not in (0, stored, again)
    space.out(("lock", 2), lease=1.0)
    leased = space.version("lock")
    clock.now = 2.0  # the lease ends: the tuple goes, and the version moves
    assert space.version("lock") not in (0, stored, again, taken, leased)


def test_an_unhashable_key_is_refused() -> None:
    with pytest.raises(TypeError):
        TupleSpace().version(["lock"])


def test_a_swept_key_goes_back_to_the_version_of_no_tuples_and_no_other_value() -> None:
    space = TupleSpace()
    space.out(("kept", 1))
    kept = space.version("kept")
    space.out(("gone", 1))
    space.inp(("gone", 1))
    gone = space.version("gone")
    for i in range(2000):  # enough emptied buckets for a sweep
        space.out((f"tag{i}", 1))
        space.inp((f"tag{i}", 1))
    assert space.version("kept") == kept
    assert space.version("gone") == 0  # no tuples, as at version 0
    space.out(("gone", 2))
    assert space.version("gone") not in (0, gone)
