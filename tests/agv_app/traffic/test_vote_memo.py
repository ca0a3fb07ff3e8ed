"""A voter decides again only when what its vote reads changed, and a seeded fleet
runs exactly as when every evaluation decides anew."""

from __future__ import annotations

import itertools
from typing import Any

import pytest

import agv_app.traffic.collision as collision
from agv_app.fleet import Fleet, FleetConfig
from agv_app.traffic.lockbook import LockBook


def run(monkeypatch: pytest.MonkeyPatch, *, memo: bool) -> tuple[dict[str, Any], int, int]:
    with monkeypatch.context() as patch:
        decided = itertools.count()
        evaluated = itertools.count()
        plain_decide, plain_evaluate = collision.decide_vote, collision.Voter._evaluate

        def decide(*args: Any, **kwargs: Any) -> str:
            next(decided)
            return plain_decide(*args, **kwargs)

        def evaluate(voter: collision.Voter) -> None:
            next(evaluated)
            plain_evaluate(voter)

        patch.setattr("agv_app.traffic.voter.decide_vote", decide)  # where Voter looks it up
        patch.setattr(collision.Voter, "_evaluate", evaluate)
        if not memo:
            # The plain path: a book whose version is new at every look.
            fresh = itertools.count()
            patch.setattr(LockBook, "version", lambda book: next(fresh))
        fleet = Fleet(None, FleetConfig(agvs=20, seed=1))
        fleet.run(40.0)
        return fleet.summary(), next(decided), next(evaluated)


@pytest.mark.source_only("replaces decide_vote and Voter._evaluate")
@pytest.mark.slow
def test_a_fleet_votes_as_if_every_evaluation_decided_anew(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    summary, decided, evaluated = run(monkeypatch, memo=True)
    plain, plain_decided, plain_evaluated = run(monkeypatch, memo=False)
    assert summary == plain
    assert summary["locks_granted"] > 0
    assert evaluated == plain_evaluated
    assert decided < plain_decided  # some evaluations found nothing changed
