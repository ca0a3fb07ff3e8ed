"""Liveliness reports become appear, restart and gone, in whichever order they come; a
run whose token went is gone only if it stays away for the grace."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces.transport.zenoh_alive import AliveTable, Change


def test_appear_restart_and_go() -> None:
    table = AliveTable("me", grace=1.0)
    assert table.token_up("a", 1) is Change.APPEARED
    assert table.token_up("a", 1) is Change.NOTHING
    assert table.token_up("a", 2) is Change.RESTARTED
    assert table.token_down("a", 1, 0.0, 0) is Change.NOTHING  # the old run's token, late
    assert table.nodes() == ["a"]
    assert table.token_down("a", 2, 0.0, 0) is Change.MISSING
    assert table.nodes() == ["a"], "missing is still a member"
    assert table.next_expiry() == 1.0
    assert table.expire(0.99) == []
    assert table.expire(1.0) == ["a"]
    assert table.nodes() == []
    assert "a" not in table
    assert table.next_expiry() is None


def test_an_older_run_reported_late_changes_nothing() -> None:
    table = AliveTable("me")
    table.token_up("a", 5)
    assert table.token_up("a", 4) is Change.NOTHING
    assert table.token_down("b", 1, 0.0, 0) is Change.NOTHING
    assert len(table) == 1


def test_our_own_token_is_no_peer() -> None:
    table = AliveTable("me")
    assert table.token_up("me", 1) is Change.NOTHING
    assert table.nodes() == []


def test_a_token_back_within_the_grace_never_left() -> None:
    """Zenoh withdraws and redeclares a token when routes between peers change."""
    table = AliveTable("me", grace=1.0)
    table.token_up("a", 3)
    assert table.token_down("a", 3, 10.0, 0) is Change.MISSING
    assert table.missing() == ["a"]
    assert table.token_up("a", 3) is Change.NOTHING
    assert table.missing() == []
    assert table.expire(20.0) == []
    assert table.nodes() == ["a"]


def test_a_run_gone_may_come_back_after_the_grace() -> None:
    table = AliveTable("me", grace=0.0)
    table.token_up("a", 3)
    table.token_down("a", 3, 0.0, 0)
    assert table.expire(0.0) == ["a"]
    assert table.token_up("a", 3) is Change.APPEARED


def test_a_restart_while_missing_replaces_the_old_run_at_once() -> None:
    table = AliveTable("me", grace=1.0)
    table.token_up("a", 3)
    table.token_down("a", 3, 0.0, 0)
    assert table.token_up("a", 4) is Change.RESTARTED
    assert table.expire(5.0) == [], "the new run is not missing"
    assert table.token_down("a", 3, 6.0, 0) is Change.NOTHING


def test_an_answer_to_a_query_sent_before_the_token_went_is_old_news() -> None:
    table = AliveTable("me", grace=1.0)
    table.token_up("a", 3)
    table.token_down("a", 3, 0.0, queries_sent=7)
    assert table.answered("a", 3, query=7) is Change.NOTHING
    assert table.missing() == ["a"], "an old answer does not bring it back"
    assert table.answered("a", 3, query=8) is Change.NOTHING  # back: it never left
    assert table.missing() == []
    table.token_down("a", 3, 2.0, queries_sent=9)
    assert table.expire(3.0) == ["a"]
    assert table.answered("a", 3, query=9) is Change.NOTHING
    assert table.answered("a", 3, query=10) is Change.APPEARED


def test_a_negative_grace_is_refused() -> None:
    with pytest.raises(ValueError, match="grace"):
        AliveTable("me", grace=-1.0)


_REPORTS = st.lists(
    st.tuples(
        st.sampled_from(["up", "down"]),
        st.sampled_from(["a", "b"]),
        st.integers(min_value=1, max_value=3),
        st.floats(min_value=0.0, max_value=2.0),  # seconds since the report before
    ),
    max_size=40,
)


@given(_REPORTS)
def test_a_run_leaves_exactly_when_its_token_stayed_away_for_the_grace(
    reports: list[tuple[str, str, int, float]],
) -> None:
    """Against a model: every run's token is up or down; a node is gone when the run
    the table holds has had its token down for a whole grace, with no newer run up."""
    grace = 1.0
    table = AliveTable("me", grace=grace)
    held: dict[str, int] = {}  # the model: the run each node is known by
    down_since: dict[str, float] = {}
    now = 0.0
    for kind, node, run, gap in reports:
        now += gap
        gone = table.expire(now)
        # ``t + grace <= now``, as the table reckons: ``now - t >= grace`` differs in the
        # last bit (down at 1.0 + 1/3, looked at 1.0 later).
        expected = sorted(n for n, t in down_since.items() if t + grace <= now)
        assert gone == expected
        for n in gone:
            del held[n], down_since[n]
        if kind == "up":
            change = table.token_up(node, run)
            if node not in held:
                assert change is Change.APPEARED
                held[node] = run
            elif run > held[node]:
                assert change is Change.RESTARTED
                held[node] = run
                down_since.pop(node, None)
            else:
                assert change is Change.NOTHING
                if run == held[node]:
                    down_since.pop(node, None)
        else:
            change = table.token_down(node, run, now, 0)
            fresh = held.get(node) == run and node not in down_since
            assert (change is Change.MISSING) is fresh
            if fresh:
                down_since[node] = now
        assert table.nodes() == sorted(held)
        assert table.missing() == sorted(down_since)


def test_a_forgotten_node_is_out_whatever_its_token_did() -> None:
    table = AliveTable("me", grace=1.0)
    table.token_up("a", 1)
    table.token_up("b", 1)
    table.token_down("b", 1, 0.0, queries_sent=0)
    assert table.forget("a") is True
    assert table.forget("b") is True
    assert table.forget("c") is False
    assert table.nodes() == []
    assert table.missing() == []
    assert table.expire(5.0) == []
