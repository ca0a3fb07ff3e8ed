"""Swagger UI and ReDoc render in real headless chromium with every outside request blocked."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

import pytest

from tests.dashboard.browser import BROWSER_MARKS, chromium_page, log_in
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.served import Served

pytestmark = BROWSER_MARKS


@pytest.fixture
def offline_page(source: NetworkSource) -> Iterator[tuple[Any, Served, list[str]]]:
    """A page whose every request to anything but 127.0.0.1 is aborted and noted."""
    blocked: list[str] = []

    def only_loopback(route: Any) -> None:
        url = route.request.url
        if urlsplit(url).hostname == "127.0.0.1":
            route.continue_()
        else:
            blocked.append(url)
            route.abort()

    with Served(source) as served, chromium_page() as (page, _):
        page.route("**/*", only_loopback)
        log_in(page, served)
        yield page, served, blocked


def test_swagger_ui_renders_offline(offline_page: tuple[Any, Served, list[str]]) -> None:
    page, served, blocked = offline_page
    page.goto(served.url + "/docs")
    page.wait_for_selector(".swagger-ui .info .title", timeout=15_000)
    assert "ObjectPlaces dashboard" in page.locator(".swagger-ui .info .title").inner_text()
    page.wait_for_selector(".opblock-summary-path[data-path='/api/tasks']", timeout=15_000)
    assert page.locator(".errors-wrapper").count() == 0
    assert blocked == []


def test_redoc_renders_offline(offline_page: tuple[Any, Served, list[str]]) -> None:
    page, served, blocked = offline_page
    page.goto(served.url + "/redoc")
    page.wait_for_selector("h1:has-text('ObjectPlaces dashboard')", timeout=15_000)
    assert blocked == []
