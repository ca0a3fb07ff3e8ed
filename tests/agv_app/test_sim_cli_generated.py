"""``objectplaces sim --layout generated:N`` and ``--heartbeat``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from objectplaces.cli import main


def test_sim_runs_on_a_generated_warehouse_with_a_long_heartbeat(tmp_path: Path) -> None:
    out = tmp_path / "m.json"
    args = ["sim", "--layout", "generated:12", "--agvs", "12", "--minutes", "0.2"]
    code = main([*args, "--heartbeat", "10", "--quiet", "--json", str(out)])
    assert code == 0
    figures = json.loads(out.read_text())
    assert figures["agvs"] == 12
    assert figures["collisions"] == 0
    assert figures["sim_seconds"] == pytest.approx(12.0)


def test_sim_refuses_a_generated_layout_without_a_size(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["sim", "--layout", "generated:none", "--quiet"]) == 2
    assert "generated:N" in capsys.readouterr().err
