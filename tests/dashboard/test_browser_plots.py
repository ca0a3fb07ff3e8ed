"""The plots panel and the history exports in real headless chromium over the AGV fleet."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

PLOTS = ("throughput", "waits", "kinds")

# How many pixels of a canvas are painted (not fully transparent).
PAINTED = """(id) => {
  const c = document.getElementById(id);
  const data = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
  let n = 0;
  for (let i = 3; i < data.length; i += 4) if (data[i] > 0) n++;
  return n;
}"""


@pytest.fixture
def plots_page() -> Iterator[tuple[Any, Served]]:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    with Served(fleet) as served:
        with chromium_page() as (page, problems):
            load_dashboard(page, served)
            yield page, served
        assert problems == [], problems


def test_the_plots_draw_the_history_and_both_exports_download_and_parse(
    plots_page: tuple[Any, Served], tmp_path: Path
) -> None:
    page, served = plots_page
    for station in ("pick-A1-1", "pick-A3-1", "pick-A1-1"):
        r = served.post("/api/tasks", {"station": station})
        assert r.status_code == 201, r.text
    r = served.post("/api/sim/speed", {"factor": 20})
    assert r.status_code == 200, r.text
    page.wait_for_function(
        "() => { const d = window.__plots.drawn;"
        " return d.throughput >= 2 && d.kinds >= 2 && d.waits > 0; }",
        timeout=40_000,
    )
    for name in PLOTS:
        canvas = page.locator(f"#plot-{name}")
        assert int(canvas.get_attribute("data-points")) > 0, name
        assert page.evaluate(PAINTED, f"plot-{name}") > 50, f"{name} is drawn"
    assert page.locator("#plot-kinds-legend li[data-kind]").count() >= 1

    with page.expect_download(timeout=10_000) as csv_download:
        page.click("#export-csv")
    csv_path = tmp_path / "history.csv"
    csv_download.value.save_as(csv_path)
    rows = list(csv.DictReader(io.StringIO(csv_path.read_text())))
    assert len(rows) >= 3
    assert float(rows[-1]["time"]) > float(rows[0]["time"])
    assert float(rows[-1]["tasks_created"]) == 3.0
    assert any(key.startswith("sent:") for key in rows[0])

    with page.expect_download(timeout=10_000) as json_download:
        page.click("#export-json")
    json_path = tmp_path / "history.json"
    json_download.value.save_as(json_path)
    body = json.loads(json_path.read_text())
    assert len(body["samples"]) >= 3
    assert body["wait_times"]["orders"] >= 1
    assert sum(body["wait_times"]["counts"]) == body["wait_times"]["orders"]
