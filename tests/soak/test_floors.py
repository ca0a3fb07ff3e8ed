"""The floor runner (``python -m tests.soak.floors``): seeds, replay commands, exit status."""

from __future__ import annotations

import dataclasses

import pytest

from tests.soak.floors import RULES, FloorResult, main, replay_command, run_floor_seed


@pytest.fixture(scope="module")
def seed_0() -> FloorResult:
    """One-way seed 0, run once for the tests that read it."""
    return run_floor_seed(0)


def test_a_seed_draws_a_crowded_floor_and_gets_work_done_safely(seed_0: FloorResult) -> None:
    assert seed_0.ok, seed_0
    assert seed_0.tasks_done > 0
    assert seed_0.run.floor.agvs >= 3
    assert run_floor_seed(0).tasks_done == seed_0.tasks_done  # a seed replays exactly


def test_a_stall_or_a_violation_fails_the_seed(seed_0: FloorResult) -> None:
    ok = seed_0
    assert not dataclasses.replace(ok, stalls=1).ok
    assert not dataclasses.replace(ok, violation="collision").ok
    assert not dataclasses.replace(ok, tasks_done=0).ok


def test_the_replay_command_names_the_kind_and_the_rules_switched_off() -> None:
    assert replay_command(7) == "python -m tests.soak.floors --seed 7"
    assert replay_command(7, ("keep_way_out", "drive_on_after")) == (
        "python -m tests.soak.floors --seed 7 --off keep_way_out --off drive_on_after"
    )
    assert replay_command(7, (), "two-way") == "python -m tests.soak.floors --kind two-way --seed 7"


def test_a_two_way_seed_draws_a_small_layout_with_dead_end_docks() -> None:
    result = run_floor_seed(3, (), "two-way")
    assert result.ok, result
    assert 2 <= result.run.floor.agvs <= 4
    docks = [s for s in result.run.floor.layout.stations.values() if s.id.startswith("dock-")]
    assert len(docks) >= 2


def test_many_seeds_print_a_summary_and_exit_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--seeds", "0-1"]) == 0
    out = capsys.readouterr().out
    assert "floors: 2 one-way seeds run (0-1 asked), rules off: none, 0 failed" in out


def test_an_unknown_rule_is_refused_with_the_known_ones(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--seed", "0", "--off", "brakes"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'brakes'" in err
    for rule in RULES:
        assert rule in err
