"""The roster a router or peer reads from the fleet's PKI folder: re-read when
``members.json`` or the revocation list changes, kept when a file cannot be read."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from objectplaces.security import CredentialError, TemporaryPki, issue, revoke
from objectplaces.transport.zenoh_acl import Roster
from objectplaces.transport.zenoh_roster import RosterWatch


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    with TemporaryPki(fleet="f") as pki:
        pki.identity("r1", role="router", addresses=("127.0.0.1",))
        pki.identity("a", role="agv")
        yield pki


def test_the_roster_follows_issuing_and_revoking(pki: TemporaryPki) -> None:
    watch = RosterWatch(pki.identity("r1"))
    assert watch.roster == Roster(members=("a",), routers=("r1",))
    assert watch.poll() is None  # nothing changed
    issue(pki.directory, "b", role="control")
    assert watch.poll() == Roster(members=("a", "b"), routers=("r1",))
    revoke(pki.directory, "a")
    assert watch.poll() == Roster(members=("b",), routers=("r1",), revoked=("a",))
    assert watch.poll() is None


def test_the_revocation_list_alone_revokes(pki: TemporaryPki) -> None:
    members = pki.directory / "members.json"
    before = members.read_bytes()
    watch = RosterWatch(pki.identity("r1"))
    revoke(pki.directory, "a")
    members.write_bytes(before)  # an index that has not heard of it yet
    assert watch.poll() == Roster(routers=("r1",), revoked=("a",))


def test_an_unreadable_members_file_keeps_the_roster(pki: TemporaryPki) -> None:
    watch = RosterWatch(pki.identity("r1"))
    members = pki.directory / "members.json"
    members.write_text("{not json")
    assert watch.poll() is None
    assert watch.roster == Roster(members=("a",), routers=("r1",))
    os.unlink(members)
    assert watch.poll() is None
    with pytest.raises(CredentialError, match=r"members\.json"):
        RosterWatch(pki.identity("r1"))
