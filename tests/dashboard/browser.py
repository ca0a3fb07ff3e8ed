"""Debian's chromium under Playwright, opened on the dashboard, for the browser tests."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest

from dashboard.auth import Role
from tests.dashboard.served import Served

__all__ = [
    "BROWSER_MARKS",
    "CHROMIUM",
    "CHROMIUM_ARGS",
    "chromium_page",
    "load_dashboard",
    "log_in",
]

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


def log_in(page: Any, served: Served, role: Role = "operator") -> None:
    """Open ``role``'s login URL of the ``served`` dashboard, as a user does, and wait
    until the login page has sent the browser on to the dashboard."""
    page.goto(served.login_url(role))
    page.wait_for_url(served.url + "/", timeout=10_000)


def load_dashboard(page: Any, served: Served, role: Role = "operator") -> None:
    """Log in (``log_in``) and wait until the dashboard's page says it is ready."""
    log_in(page, served, role)
    page.wait_for_function("window.__dashboard && window.__dashboard.ready", timeout=10_000)
