"""Liveliness reports become appear, restart and gone, in whichever order they come."""

from __future__ import annotations

from objectplaces.transport.zenoh_alive import AliveTable, Change


def test_appear_restart_and_go() -> None:
    table = AliveTable("me")
    assert table.token_up("a", 1) is Change.APPEARED
    assert table.token_up("a", 1) is Change.NOTHING
    assert table.token_up("a", 2) is Change.RESTARTED
    assert table.token_down("a", 1) is Change.NOTHING  # the old run's token, late
    assert table.nodes() == ["a"]
    assert table.token_down("a", 2) is Change.GONE
    assert table.nodes() == []
    assert "a" not in table


def test_an_older_run_reported_late_changes_nothing() -> None:
    table = AliveTable("me")
    table.token_up("a", 5)
    assert table.token_up("a", 4) is Change.NOTHING
    assert table.token_down("b", 1) is Change.NOTHING
    assert len(table) == 1


def test_our_own_token_is_no_peer() -> None:
    table = AliveTable("me")
    assert table.token_up("me", 1) is Change.NOTHING
    assert table.nodes() == []


def test_a_run_gone_may_come_back() -> None:
    """Zenoh withdraws and redeclares a token when routes between peers change."""
    table = AliveTable("me")
    table.token_up("a", 3)
    assert table.token_down("a", 3) is Change.GONE
    assert table.token_up("a", 3) is Change.APPEARED
    assert table.nodes() == ["a"]
