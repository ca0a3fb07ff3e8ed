"""The fleet's key expressions: escaping ids, the keys we put, and reading keys back."""

from __future__ import annotations

import pytest
import zenoh
from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core.errors import LocalProtocolError
from objectplaces.transport.zenoh_keys import FleetKeys, Inbound, escape_id, unescape_id


@given(st.text(min_size=1, max_size=30))
def test_any_id_escapes_to_one_chunk_and_back(node: str) -> None:
    chunk = escape_id(node)
    assert "/" not in chunk
    assert "*" not in chunk
    assert "$" not in chunk
    assert unescape_id(chunk) == node
    zenoh.KeyExpr(f"a/{chunk}/b")  # a valid key expression


@pytest.mark.parametrize("chunk", ["", "%", "%G1", "a b", "*", "%61", "%FF"])
def test_what_is_no_escaped_id_is_refused(chunk: str) -> None:
    # "%61" is "a" escaped needlessly: only the one canonical spelling is an id.
    assert unescape_id(chunk) is None


def test_keys_of_one_node() -> None:
    keys = FleetKeys("fleet-1", "agv/3")
    assert keys.props((1, -2)) == "objectplaces/fleet-1/props/1,-2/agv%2F3"
    assert keys.props((0, 0), left=True) == "objectplaces/fleet-1/props/0,0/agv%2F3/left"
    assert keys.to("b") == "objectplaces/fleet-1/to/b/agv%2F3"
    assert keys.inbox() == "objectplaces/fleet-1/to/agv%2F3/*"
    assert keys.who(None) == "objectplaces/fleet-1/who/none/agv%2F3"


def test_a_cell_subscription_hears_both_copies_full_dissemination_one() -> None:
    keys = FleetKeys("f", "n")
    cell = zenoh.KeyExpr(keys.cell_subscription((1, 2)))
    full = zenoh.KeyExpr(keys.all_props())
    primary, left = keys.props((1, 2)), keys.props((1, 2), left=True)
    assert cell.intersects(primary)
    assert cell.intersects(left)
    assert full.intersects(primary)
    assert not full.intersects(left)
    assert not cell.intersects(keys.props((1, 3)))


def test_a_row_subscription_hears_every_cell_of_its_row_and_no_other() -> None:
    keys = FleetKeys("f", "n")
    row = zenoh.KeyExpr(keys.row_subscription(-3))
    for cell in [(0, -3), (-12, -3), (405, -3)]:
        assert row.intersects(keys.props(cell))
        assert row.intersects(keys.props(cell, left=True))
    for cell in [(0, 3), (1, -13), (-3, 0), (-3, -31)]:
        assert not row.intersects(keys.props(cell))


def test_parse_reads_kind_and_sender() -> None:
    me, other = FleetKeys("f", "me"), FleetKeys("f", "x y")
    assert me.parse(other.props((1, 1))) == Inbound("props", "x y", (1, 1))
    assert me.parse(other.props((-3, 1), left=True)) == Inbound("props", "x y", (-3, 1))
    assert me.parse(other.broadcast()) == Inbound("all", "x y")
    assert me.parse(other.to("me")) == Inbound("to", "x y")
    assert me.parse(other.alive(7)) is None
    assert me.parse_alive(other.alive(7)) == ("x y", 7, "")
    tagged = FleetKeys("f", "t", "layout:ab/c d")
    assert me.parse_alive(tagged.alive(3)) == ("t", 3, "layout:ab/c d")


@pytest.mark.parametrize(
    "key",
    [
        "objectplaces/g/all/x",  # another fleet
        "objectplaces/f/to/someone-else/x",
        "objectplaces/f/props/1,1/x/right",
        "objectplaces/f/props/1,1",
        "objectplaces/f/props/1;1/x",  # not a cell
        "objectplaces/f/props/1,/x",
        "objectplaces/f/props/01,1/x",  # a cell written another way
        "objectplaces/f/all/x%ZZ",
        "objectplaces/f/unknown/x",
        "elsewhere",
    ],
)
def test_parse_refuses_keys_that_are_none_of_ours(key: str) -> None:
    keys = FleetKeys("f", "me")
    assert keys.parse(key) is None
    assert keys.parse_alive(key) is None


@pytest.mark.parametrize("fleet", ["", "a/b", "a*", "x" * 65])
def test_a_bad_fleet_name_is_refused(fleet: str) -> None:
    with pytest.raises(LocalProtocolError):
        FleetKeys(fleet, "n")
