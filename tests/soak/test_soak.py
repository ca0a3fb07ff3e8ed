"""The simulation suite in CI: a fixed set of seeds, and checks of the suite itself.

``OP_SEED=<n>`` runs that one seed instead of the fixed set. ``make soak SEEDS=N`` runs
many more (docs/soak.md).
"""

from __future__ import annotations

import os
from collections import Counter
from dataclasses import replace

import pytest

from tests.soak import invariants
from tests.soak.hostile import FORGERIES
from tests.soak.probes import (
    Activated,
    Deactivated,
    InGroup,
    InitiatorHeard,
    OutGroup,
    ParticipantHeard,
)
from tests.soak.runner import RunResult, main, parse_seeds, replay_command, run_seed
from tests.soak.workload import Inject, Link, Settle, Start, Step, generate

CI_SEEDS = list(range(1, 21))
SEEDS = [int(os.environ["OP_SEED"])] if os.environ.get("OP_SEED") else CI_SEEDS


def _explain(result: RunResult) -> str:
    lines = [f"seed {result.seed} failed at {result.failed_step}", *result.violations[:10]]
    return "\n".join([*lines, f"replay: {replay_command(result.seed)}"])


@pytest.mark.parametrize("seed", SEEDS)
def test_every_invariant_holds_after_every_step(seed: int) -> None:
    result = run_seed(seed)
    assert result.ok, _explain(result)
    assert result.steps == len(generate(seed).steps)  # it ran to the end
    assert result.convergence  # it reached every calm checkpoint


def test_a_long_run_keeps_state_bounded() -> None:
    # Ten chaos phases: at each calm checkpoint a node's state is bounded by the sessions
    # that run (state_within_bounds), its view by the live nodes, and at the end nothing
    # is left; none of it may grow with the length of the run.
    result = run_seed(2, phases=10)
    assert result.ok, _explain(result)
    assert len(result.convergence) == 10


def test_a_seed_replays_exactly() -> None:
    first, second = run_seed(5), run_seed(5)
    assert (first.steps, first.virtual_seconds, first.frames, first.facts) == (
        second.steps,
        second.virtual_seconds,
        second.frames,
        second.facts,
    )
    assert first.convergence == second.convergence


def test_the_scenario_is_a_function_of_the_seed() -> None:
    assert generate(7) == generate(7)
    assert generate(7) != generate(8)


def _kinds(steps: tuple[Step, ...]) -> Counter[str]:
    return Counter(type(step).__name__ for step in steps)


def test_the_fixed_seeds_exercise_every_kind_of_trouble() -> None:
    scenarios = [generate(seed) for seed in CI_SEEDS]
    kinds = sum((_kinds(s.steps) for s in scenarios), Counter())
    expected = {
        "Move",
        "Start",
        "Stop",
        "InitiatorSends",
        "ParticipantSends",
        "Wait",
        "Crash",
        "Leave",
        "Restart",
        "Join",
        "Partition",
        "Heal",
        "Link",
        "Inject",
        "StopAll",
        "Settle",
    }
    assert expected <= set(kinds)
    definitions = {
        step.definition[0] for s in scenarios for step in s.steps if isinstance(step, Start)
    }
    assert definitions == {"overlap", "within", "near", "overlap_team", "within_or_team"}
    forgeries = {step.kind for s in scenarios for step in s.steps if isinstance(step, Inject)}
    assert forgeries == set(FORGERIES)
    links = [step for s in scenarios for step in s.steps if isinstance(step, Link)]
    assert max(link.loss for link in links) == 0.2
    assert max(s.loss for s in scenarios) == 0.2
    assert any(s.duplicate for s in scenarios)
    assert any(s.reorder for s in scenarios)
    assert any(s.interest_radius is not None for s in scenarios)
    assert any(s.interest_radius is None for s in scenarios)
    bursts = [
        step.count  # type: ignore[union-attr]
        for s in scenarios
        for step in s.steps
        if type(step).__name__ in ("InitiatorSends", "ParticipantSends")
    ]
    assert max(bursts) >= 50
    assert all(s.steps[-1] == Settle(final=True) for s in scenarios)


# ---------------------------------------------------------------- the checks catch


HEARD = InitiatorHeard(1.0, "a#1", "b", "a#1", True, True, "a#1", 4, 0, 0)
TOLD = ParticipantHeard(1.0, "b", "a#1", 4, True, "a#1", 1, 1, 3, 3)
ACTIVATED = Activated(1.0, "b", "a#1", 4, "probe", frozenset({"probe"}), "probe", True)


def test_a_message_from_a_member_in_order_passes() -> None:
    assert invariants.judge([HEARD, TOLD, ACTIVATED]) == []


@pytest.mark.parametrize(
    ("fact", "code"),
    [
        (replace(HEARD, notified_member=False), "G1"),
        (replace(HEARD, middleware_member=False), "G1"),
        (replace(HEARD, sender_session="a#2"), "G1"),
        (replace(HEARD, tag="c#1"), "G1"),
        (replace(HEARD, k=1), "G5"),
        (replace(TOLD, active=False), "G4"),
        (replace(TOLD, tag="c#1"), "G1"),
        (replace(TOLD, gen=2), "G5"),
        (replace(TOLD, k=2), "G5"),
        (replace(TOLD, k=4), "G5"),
        (replace(ACTIVATED, registered=frozenset({"decoy"})), "G3"),
        (replace(ACTIVATED, requested="decoy"), "G3"),
        (replace(ACTIVATED, fresh=False), "G3"),
        (InGroup(1.0, "a#1", "b", False, False), "G3"),
    ],
)
def test_a_broken_guarantee_is_named(fact: object, code: str) -> None:
    found = invariants.judge([fact])  # type: ignore[list-item]
    assert found
    assert found[0].startswith(code), found


@pytest.mark.parametrize(
    "fact",
    [
        InGroup(1.0, "a#1", "b", True, True),
        OutGroup(1.0, "a#1", "b", False),
        Deactivated(1.0, "b", "a#1", 4, False),
    ],
)
def test_callbacks_out_of_order_are_named(fact: object) -> None:
    assert invariants.judge([fact])  # type: ignore[list-item]


def test_a_hostile_session_is_not_held_to_the_probes_numbering() -> None:
    hostile = replace(TOLD, sid="x-hostile#3", tag=None, k=None, gen=None)
    assert invariants.judge([hostile]) == []


# ---------------------------------------------------------------- the runner


def test_seed_ranges_parse() -> None:
    assert parse_seeds("1-3,7,10-11") == [1, 2, 3, 7, 10, 11]


def test_a_replay_prints_its_steps_and_passes(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--seed", "3"]) == 0
    out = capsys.readouterr().out
    assert "   0 t=   0.000" in out
    assert out.rstrip().endswith("seed 3: ok")


def test_the_replay_command_names_the_seed() -> None:
    assert replay_command(42) == "OP_SEED=42 python -m tests.soak.runner --seed 42"
