"""``objectplaces sim``: figures, JSON keys and exit status."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agv_app import fleet as fleet_module
from agv_app.tasks import DEFAULT_LOAD
from objectplaces.cli import main

KEYS = {
    "collisions",
    "lock_overlaps",
    "deadlocks",
    "tasks_created",
    "tasks_completed",
    "messages",
    "bytes",
    "bytes_per_agv_per_s",
    "sim_seconds",
    "wall_seconds",
    "tasks_per_hour",
    "task_time_mean",
    "task_time_p95",
    "idle_share",
    "waiting_share",
    "lock_wait_mean",
}


def test_sim_writes_the_metrics_and_exits_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "m.json"
    code = main(["sim", "--agvs", "3", "--minutes", "1", "--seed", "2", "--json", str(out)])
    assert code == 0
    figures = json.loads(out.read_text())
    assert figures.keys() >= KEYS
    assert figures["sim_seconds"] == pytest.approx(60.0)
    assert figures["collisions"] == figures["lock_overlaps"] == figures["deadlocks"] == 0
    assert "bytes_per_agv_per_s" in capsys.readouterr().out


DEMO_01 = Path(__file__).resolve().parents[2] / "agv_app/data/opentcs/Demo-01.xml"


def test_an_opentcs_layout_runs_a_fleet_of_its_parking_capacity(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "demo01.json"
    code = main(["sim", "--layout", str(DEMO_01), "--minutes", "4", "--quiet", "--json", str(out)])
    assert code == 0
    figures = json.loads(out.read_text())
    assert figures["agvs"] == 5  # Demo-01 has five parking places
    assert figures["collisions"] == figures["lock_overlaps"] == figures["deadlocks"] == 0
    assert figures["tasks_created"] > 0
    assert "has 5 parking places; running 5 AGVs" in capsys.readouterr().err


def test_more_agvs_than_parking_places_is_refused_clearly(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["sim", "--layout", str(DEMO_01), "--agvs", "20", "--minutes", "1", "--quiet"])
    assert code == 2
    assert "5 parking places, too few for 20 AGVs" in capsys.readouterr().err


def test_a_plant_without_two_stations_that_reach_each_other_is_refused_with_why(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The openTCS V7 sample: its one location lies behind a locked path, its paths join
    # no two stations, and its park position has no path at all.
    sample = DEMO_01.with_name("PlantModelV7.sample.xml")
    assert main(["sim", "--layout", str(sample), "--agvs", "1", "--minutes", "1", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "layout 'PlantModelV7' cannot host a fleet" in err
    assert "a pick station and another drop station that reach each other" in err
    assert "'Location-0001' (pickdrop), cut off from it: 'Point-0015' (parking)" in err


def test_broadcast_and_an_opentcs_layout(tmp_path: Path) -> None:
    layout = DEMO_01
    code = main(["sim", "--agvs", "4", "--minutes", "1", "--layout", str(layout), "--quiet"])
    assert code == 0
    code = main(["sim", "--agvs", "3", "--minutes", "0.5", "--broadcast", "--quiet"])
    assert code == 0


def _report(monkeypatch: pytest.MonkeyPatch, **figures: float) -> None:
    """Make every fleet report ``figures`` on top of what it measured."""
    real = fleet_module.Fleet.summary

    def changed(self: fleet_module.Fleet, wall_seconds: float = 0.0) -> dict[str, float]:
        return {**real(self, wall_seconds), **figures}

    monkeypatch.setattr(fleet_module.Fleet, "summary", changed)


def test_exit_status_is_one_when_a_safety_figure_is_not_zero(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    _report(monkeypatch, collisions=1)
    assert main(["sim", "--agvs", "2", "--minutes", "0.2", "--quiet"]) == 1


def test_bad_arguments_and_a_bad_layout_exit_two(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["sim", "--agvs", "0", "--quiet"])
    assert exit_.value.code == 2
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    assert main(["sim", "--layout", str(bad), "--quiet"]) == 2


def test_sim_runs_at_the_default_load_and_reports_the_new_figures(tmp_path: Path) -> None:
    from objectplaces.cli import build_parser

    args = build_parser().parse_args(["sim"])
    assert args.load == DEFAULT_LOAD
    assert args.task_interval is None
    out = tmp_path / "m.json"
    argv = ["sim", "--agvs", "3", "--minutes", "0.5", "--load", "0.7", "--quiet"]
    code = main([*argv, "--json", str(out)])
    assert code == 0
    figures = json.loads(out.read_text())
    assert figures["tasks_created"] >= 2, "load 0.7 of 3 AGVs: 2 tasks at the start"
    assert {"free_flow_tasks_per_hour", "stalls_60s", "max_wait"} <= figures.keys()


@pytest.mark.parametrize("load", ["0", "1.5", "-0.2", "nan"])
def test_sim_refuses_a_load_outside_zero_to_one(
    load: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["sim", "--agvs", "2", "--minutes", "1", "--load", load])
    assert exit_.value.code == 2
    assert f"argument --load: expected a number in (0, 1], got {load!r}" in (
        capsys.readouterr().err
    )


def test_sim_refuses_a_task_interval_that_is_not_positive(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["sim", "--agvs", "2", "--minutes", "1", "--task-interval", "0"])
    assert exit_.value.code == 2
    assert "argument --task-interval: expected a number > 0, got '0'" in capsys.readouterr().err


def test_sim_refuses_a_bad_rest_beat(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sim", "--agvs", "2", "--minutes", "1", "--quiet", "--rest-beat"]
    for bad, said in (
        ("0", "expected seconds > 0 or 'none'"),
        ("soon", "expected seconds > 0 or 'none'"),
        ("nan", "expected seconds > 0 or 'none'"),
    ):
        with pytest.raises(SystemExit) as exit_:
            main([*args, bad])
        assert exit_.value.code == 2
        assert f"{said}, got {bad!r}" in capsys.readouterr().err


def test_sim_runs_without_rest_beats(tmp_path: Path) -> None:
    out = tmp_path / "m.json"
    args = ["sim", "--agvs", "2", "--minutes", "1", "--quiet", "--json", str(out)]
    assert main([*args, "--rest-beat", "none"]) == 0
    assert json.loads(out.read_text())["collisions"] == 0


@pytest.mark.parametrize("limit", ["none", None, "3"])
def test_waits_past_the_limit_point_to_the_task_desk_limit(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], limit: str | None
) -> None:
    _report(monkeypatch, deadlocks=2)
    extra = [] if limit is None else ["--max-open-tasks", limit]
    assert main(["sim", "--agvs", "2", "--minutes", "0.2", "--quiet", *extra]) == 1
    err = capsys.readouterr().err
    hint = "2 waits passed 180 s. A fleet larger than its floor carries fills the lanes"
    # Only without a limit: 2 AGVs are fewer than the floor carries, so by default none.
    assert (hint in err) is (limit != "3")
    # The demo warehouse's 434 m of one-way lane and 25 m of keep-clear boxes (two-way
    # pieces routes drive through), at one task per 20 m.
    assert ("this floor carries about 22 (one per 20 m of lane)" in err) is (limit != "3")


def test_sim_with_batteries_reports_the_state_of_charge(tmp_path: Path) -> None:
    out = tmp_path / "m.json"
    args = ["sim", "--agvs", "3", "--minutes", "1", "--batteries", "--quiet", "--json", str(out)]
    assert main(args) == 0
    figures = json.loads(out.read_text())
    assert figures["ran_empty"] == 0
    assert 90.0 < figures["min_state_of_charge"] < 100.0
    assert figures["charges"] == 0


def test_sim_closes_parts_of_the_floor_from_the_start(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "m.json"
    args = ["sim", "--agvs", "3", "--minutes", "1", "--seed", "2", "--json", str(out)]
    code = main([*args, "--close", "segment:M4550>M3925", "--close", "polygon:30,8;31,8;31,10"])
    assert code == 0
    assert json.loads(out.read_text())["collisions"] == 0
    assert main([*args, "--close", "segment:A1-1>A1-1e"]) == 2
    assert "every way out of station(s) pick-A1-1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([*args, "--close", "lane:X"])
