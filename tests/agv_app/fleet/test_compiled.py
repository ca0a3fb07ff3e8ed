"""The compiled build (agv_app.fleet.compiled) runs a fleet to the same figures."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from agv_app.fleet.compiled import SIM_MODULES, sim_build
from objectplaces.compiled import default_cache, find_built

pytestmark = [
    pytest.mark.slow,
    # Fleets run as child processes, and one test type-checks the whole build: seconds
    # on a quiet machine, minutes on a loaded one; the bound only catches a hang.
    pytest.mark.timeout(900),
    pytest.mark.source_only("compares the source with the build"),
]

ROOT = Path(__file__).resolve().parents[3]

_RUN = """
import json, sys
from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.compiled import SIM_MODULES
from objectplaces.compiled import loaded_compiled
agvs, seconds = json.loads(sys.argv[1])
# Every winner called at once, no limit: the bench's heavy case, a jam of waits and votes.
fleet = Fleet(None, FleetConfig(agvs=agvs, seed=4, one_at_a_time=False, max_open_tasks=None))
fleet.run(seconds)
summary = fleet.summary(1.0)
print(json.dumps({"summary": summary, "compiled": loaded_compiled(SIM_MODULES)}))
"""


@pytest.fixture(scope="module")
def build() -> Path:
    """The build ``make test`` made before the suite; a test never compiles it, as a cold
    build takes minutes on a busy machine."""
    tree = find_built(sim_build())
    if tree is None:
        pytest.fail(
            f"no compiled build of this source in {default_cache()}: make it first with "
            "`make compiled` (or `.venv/bin/python -m agv_app.fleet.compiled`)"
        )
    return tree


def _run(path: list[Path], args: list[Any]) -> dict[str, Any]:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(str(p) for p in path)}
    done = subprocess.run(
        [sys.executable, "-P", "-c", _RUN, json.dumps(args)],
        env=env,
        cwd=path[0],
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def test_a_jammed_fleet_runs_to_the_same_figures_compiled(build: Path) -> None:
    source = _run([ROOT], [40, 60.0])
    compiled = _run([build, ROOT], [40, 60.0])
    assert source["compiled"] == []
    assert compiled["compiled"] == list(SIM_MODULES)
    assert source["summary"]["locks_granted"] > 50  # the run votes and grants
    assert compiled["summary"] == source["summary"]


def test_sim_compiled_prints_the_same_figures_and_says_so(build: Path, tmp_path: Path) -> None:
    def sim(*extra: str) -> tuple[dict[str, Any], str]:
        out = tmp_path / f"figures{len(extra)}.json"
        command = [sys.executable, "-P", "-m", "objectplaces.cli", "sim", "--agvs", "6"]
        command += ["--minutes", "1", "--quiet", "--json", str(out), *extra]
        env = {**os.environ, "PYTHONPATH": str(ROOT)}
        done = subprocess.run(
            command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300
        )
        assert done.returncode == 0, done.stderr
        figures = json.loads(out.read_text())
        for timing in ("wall_seconds", "sim_speed"):
            figures.pop(timing)
        return figures, done.stderr

    plain, plain_err = sim()
    fast, fast_err = sim("--compiled")
    assert fast == plain
    assert "compiled:" not in plain_err
    assert f"compiled: {len(SIM_MODULES)} of {len(SIM_MODULES)} modules from {build}" in fast_err


def test_sim_compiled_without_a_c_compiler_says_why_and_exits_1(tmp_path: Path) -> None:
    # An empty cache, and a C compiler that always fails: the build cannot be made.
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT),
        "XDG_CACHE_HOME": str(tmp_path / "cache"),
        "CC": "/bin/false",
    }
    command = [sys.executable, "-P", "-m", "objectplaces.cli", "sim", "--compiled"]
    command += ["--agvs", "2", "--minutes", "0.1", "--quiet"]
    done = subprocess.run(
        command, env=env, cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 1
    assert "objectplaces sim: --compiled: mypyc build failed" in done.stderr
    assert "run without --compiled for the same run from the source" in done.stderr
    assert not list((tmp_path / "cache" / "objectplaces").glob("compiled-*"))
