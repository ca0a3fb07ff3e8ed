"""Closing and reopening a path in real headless chromium: the panel closes it, the
floor plan draws it closed, and reopening takes the drawing away."""

from __future__ import annotations

from agv_app.fleet import Fleet, FleetConfig
from tests.dashboard.browser import BROWSER_MARKS, chromium_page, load_dashboard
from tests.dashboard.canvas import PIXEL
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS

LANE = "M4550>M3925"
CLOSED_RGB = (255, 90, 54)


def _near(rgb: list[int], want: tuple[int, int, int]) -> bool:
    return all(abs(a - b) <= 40 for a, b in zip(rgb, want, strict=True))


def test_a_closed_path_is_drawn_and_reopening_removes_it() -> None:
    fleet = Fleet(config=FleetConfig(agvs=2, seed=3, task_until=0.0))
    (x0, y0), (x1, y1) = fleet.layout.segment_coords(LANE)
    with Served(fleet) as served, chromium_page() as (page, problems):
        load_dashboard(page, served)
        page.wait_for_function("window.__blocksPanel !== undefined", timeout=10_000)
        # A point on the path, a quarter of the way along: a dash of the closed line.
        where = page.evaluate(
            f"window.__dashboard.screenPosition({x0 + (x1 - x0) / 4}, {y0 + (y1 - y0) / 4})"
        )
        spot = [where["x"], where["y"]]
        assert not _near(page.evaluate(PIXEL, spot), CLOSED_RGB), "open: not drawn closed"

        page.get_by_test_id("blocks-what").fill(LANE)
        page.get_by_test_id("blocks-reason").fill("spill")
        page.get_by_test_id("blocks-close").click()
        page.wait_for_function(
            f"window.__blocksPanel.drawnSegments.includes('{LANE}')", timeout=10_000
        )
        row = page.locator("tr[data-block-id='b1']")
        assert row.locator("td").nth(2).text_content() == LANE
        assert page.get_by_test_id("blocks-status").text_content() == "closed b1: 1 paths, 0 points"
        page.wait_for_function(
            f"(() => {{ const c = ({PIXEL})({spot}); return c[0] > 200 && c[1] < 140; }})()",
            timeout=10_000,
        )
        listed = served.get("/api/blocks").json()
        assert [b["id"] for b in listed["blocks"]] == ["b1"]

        row.get_by_role("button", name="Reopen").click()
        page.wait_for_function("window.__blocksPanel.ids.length === 0", timeout=10_000)
        page.wait_for_function("window.__blocksPanel.drawnSegments.length === 0", timeout=10_000)
        assert page.locator("tr[data-block-id]").count() == 0
        assert not _near(page.evaluate(PIXEL, spot), CLOSED_RGB), "reopened: drawn open"
        assert served.get("/api/blocks").json()["blocks"] == []
        events = served.get("/api/events").json()["events"]
        texts = [e["text"] for e in events if e["source"] == "floor"]
        assert texts[0].startswith(f"b1 (segment {LANE}) closed by operator")
        assert texts[1].startswith(f"b1 (segment {LANE}) reopened by operator")
        assert problems == [], problems
