"""The dashboard server: REST API, the ``/ws/events`` feed, and the page.

``create_app(source)`` wraps any running fleet (``FleetSource``). Endpoints and the feed
format: ``docs/dashboard.md``.

Concurrency model: one thread of control. Everything that touches the fleet or a node
runs on the app's event loop: the fleet driver (``dashboard.driver``, one task started
with the app's lifespan), every route and dependency (all ``async def``, so FastAPI
never sends one to a worker thread), and the feed's per-socket tasks. No handler awaits
between reading the fleet and acting on it, so each request sees and changes the fleet
as one step between two steps of the driver, and nothing needs a lock. GET handlers
only read; the driver alone forgets sessions that ended. The one blocking call made for
a request, the file read behind ``GET /``, touches no state.
"""

from __future__ import annotations

import asyncio
import inspect
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from dashboard.driver import FleetDriver
from dashboard.errors import install_error_handlers
from dashboard.history import HistorySampler, MetricsHistory
from dashboard.limits import RequestLimits
from dashboard.routes import ROUTERS
from dashboard.routes.docs import DOCS_ASSETS_DIR, DOCS_ASSETS_URL
from dashboard.routes.history import router as history_router
from dashboard.source import FleetSource
from dashboard.state import DashboardState

__all__ = ["STATIC_DIR", "create_app"]

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
"""Where the page's files live (``static/`` beside the package)."""


def create_app(
    source: FleetSource,
    *,
    token: str | None = None,
    tick_s: float = 0.02,
    static_dir: Path = STATIC_DIR,
) -> FastAPI:
    """Build the dashboard app around a running fleet.

    Args:
        source: the fleet; the app advances it while it runs (lifespan).
        token: when set, every mutating request (POST, DELETE) must carry
            ``Authorization: Bearer <token>``; the page takes it from ``?token=``.
        tick_s: how often the fleet is advanced, in wall-clock seconds.
        static_dir: the page's files.

    Returns:
        The FastAPI app (OpenAPI at ``/docs`` and ``/redoc``, served with no internet).
    """
    state = DashboardState(source, token=token)
    state.ensure_responders()
    driver = FleetDriver(state, tick_s=tick_s)
    history = MetricsHistory()
    sampler = HistorySampler(state, history)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # A fleet of separate processes starts and stops with the app (optional hooks).
        start, stop = getattr(source, "start", None), getattr(source, "stop", None)
        if inspect.iscoroutinefunction(start):
            await start()
        try:
            async with asyncio.TaskGroup() as tasks:
                runners = [tasks.create_task(driver.run()), tasks.create_task(sampler.run())]
                try:
                    yield
                finally:
                    for runner in runners:
                        runner.cancel()
        finally:
            if inspect.iscoroutinefunction(stop):
                await stop()

    app = FastAPI(
        title="ObjectPlaces dashboard",
        summary="Live fleet: nodes, sessions, groups, locks; start sessions and tasks.",
        version="0.1.0",
        lifespan=lifespan,
        docs_url=None,
        redoc_url=None,
    )
    app.state.dashboard = state
    app.state.driver = driver
    app.state.history = history
    app.state.static_dir = static_dir
    app.add_middleware(RequestLimits)
    install_error_handlers(app)
    for router in (*ROUTERS, history_router):
        app.include_router(router)
    app.mount("/static", StaticFiles(directory=static_dir), name="static")
    app.mount(DOCS_ASSETS_URL, StaticFiles(directory=DOCS_ASSETS_DIR), name="docs-assets")
    return app
