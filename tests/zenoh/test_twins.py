"""A second process with a member's id is told so: the later run sees the earlier run's
token of its own id stay up (past the lease of a run that died), the earlier sees none."""

from __future__ import annotations

import pytest

from objectplaces.security import TemporaryPki
from objectplaces.zenoh_node import start_zenoh_node
from tests.waiting import until


@pytest.fixture
def pki() -> TemporaryPki:
    made = TemporaryPki(fleet="f")
    made.identity("a", role="agv")
    return made


async def test_the_later_of_two_runs_with_one_id_sees_its_twin(pki: TemporaryPki) -> None:
    first = await start_zenoh_node("a", tls=pki.identity("a"))
    second = await start_zenoh_node("a", tls=pki.identity("a"), connect=first.address.split(","))
    try:
        await until(lambda: second.twin_up_for() is not None, 60)
        await until(lambda: (second.twin_up_for() or 0.0) > 1.0, 60)
        assert first.twin_up_for() is None  # the earlier run stays
        await first.close()
        await until(lambda: second.twin_up_for() is None, 60)  # gone with its token
    finally:
        await second.close()
        await first.close()
        pki.remove()
