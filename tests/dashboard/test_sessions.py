"""Starting a session over HTTP is all or nothing."""

from __future__ import annotations

from typing import Any

import pytest
from fastapi import HTTPException

from dashboard.poll import PollInitiator
from dashboard.routes.sessions import start_or_undo
from objectplaces import Initiator, RoleActivator, Session, groups
from tests.dashboard.conftest import NetworkSource


class FailsAfterStarting:
    """A real node whose ``start_interaction`` raises once the session exists."""

    def __init__(self, node: RoleActivator, error: BaseException) -> None:
        self.node = node
        self.error = error

    def start_interaction(self, initiator: Initiator, definition: Any, role: str) -> Session:
        self.node.start_interaction(initiator, definition, role)
        raise self.error

    def __getattr__(self, name: str) -> Any:
        return getattr(self.node, name)


def live_ids(node: RoleActivator) -> list[str]:
    return [str(s.session_id) for s in node.sessions()]


def test_a_start_that_fails_on_bad_input_is_undone_and_422(source: NetworkSource) -> None:
    node = source.nodes()["agv-1"]
    kept = node.start_interaction(PollInitiator("status"), groups.within(5.0), "poll-responder")
    failing = FailsAfterStarting(node, OverflowError("cannot convert float infinity"))
    with pytest.raises(HTTPException) as refused:
        start_or_undo(failing, PollInitiator("status"), groups.within(5.0), "poll-responder")
    assert refused.value.status_code == 422
    assert "cannot start the session: cannot convert float infinity" in refused.value.detail
    assert live_ids(node) == [str(kept.session_id)]


def test_a_start_that_fails_otherwise_is_undone_and_reraised(source: NetworkSource) -> None:
    node = source.nodes()["agv-1"]
    failing = FailsAfterStarting(node, MemoryError())
    with pytest.raises(MemoryError):
        start_or_undo(failing, PollInitiator("status"), groups.within(5.0), "poll-responder")
    assert live_ids(node) == []


def test_a_start_that_works_returns_its_session(source: NetworkSource) -> None:
    node = source.nodes()["agv-1"]
    handle = start_or_undo(node, PollInitiator("status"), groups.within(5.0), "poll-responder")
    assert live_ids(node) == [str(handle.session_id)]
