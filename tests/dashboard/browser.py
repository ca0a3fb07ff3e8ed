"""Debian's chromium under Playwright, opened on the dashboard, for the browser tests."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

__all__ = ["BROWSER_MARKS", "CHROMIUM", "CHROMIUM_ARGS", "chromium_page", "load_dashboard"]

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--headless",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
]
BROWSER_MARKS = [
    pytest.mark.browser,
    pytest.mark.skipif(not CHROMIUM.exists(), reason="needs /usr/bin/chromium (make chromium)"),
]
"""The marks of every browser test module (``pytestmark = BROWSER_MARKS``)."""


@contextmanager
def chromium_page(*, width: int = 1400, height: int = 900) -> Iterator[tuple[Any, list[str]]]:
    """A fresh headless chromium page, and the console errors and page errors it logs.

    The browser closes when the block ends, before the caller looks at the problems.
    """
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            problems: list[str] = []
            page.on(
                "console",
                lambda m: problems.append(f"{m.type}: {m.text}") if m.type == "error" else None,
            )
            page.on("pageerror", lambda e: problems.append(f"pageerror: {e}"))
            yield page, problems
        finally:
            browser.close()


def load_dashboard(page: Any, url: str) -> None:
    """Open the dashboard at ``url`` and wait until its page says it is ready."""
    page.goto(url + "/")
    page.wait_for_function("window.__dashboard && window.__dashboard.ready", timeout=10_000)
