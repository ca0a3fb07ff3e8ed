"""The dashboard server: REST API, the ``/ws/events`` feed, and the page.

``create_app(source)`` wraps any running fleet (``FleetSource``). Endpoints and the feed
format: ``docs/dashboard.md``. Every request and the feed pass ``dashboard.guard`` first:
the caller's ``Host``, ``Origin``, role (``dashboard.auth``) and body type.

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
from collections.abc import AsyncIterator, Iterable
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles
from starlette.middleware.trustedhost import TrustedHostMiddleware

from dashboard.auth import Logins, Tokens
from dashboard.driver import FleetDriver
from dashboard.errors import install_error_handlers
from dashboard.eventlog import EventLog
from dashboard.guard import LOOPBACK_HOSTS, AccessGuard
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
    tokens: Tokens | None = None,
    hosts: Iterable[str] = (),
    tick_s: float = 0.02,
    static_dir: Path = STATIC_DIR,
    events: EventLog | None = None,
) -> FastAPI:
    """Build the dashboard app around a running fleet.

    Args:
        source: the fleet; the app advances it while it runs (lifespan).
        tokens: the operator's and the viewer's token (default: a new random pair, in
            ``app.state.tokens``); every request and the feed need one of them, as a
            Bearer token or traded for a login cookie at ``POST /login``.
        hosts: the names (or addresses) clients reach the server by, besides the
            loopback ones; a request naming any other ``Host`` is refused (400).
        tick_s: how often the fleet is advanced, in wall-clock seconds.
        static_dir: the page's files.
        events: the operator's log (default: a new one in memory; the control gives one
            on its order store, ``EventLog(store=...)``, so that the log outlives it).

    Returns:
        The FastAPI app (OpenAPI at ``/docs`` and ``/redoc``, served with no internet).

    Raises:
        ValueError: a host given as a pattern (``*``), which would let any name in.
    """
    hosts = tuple(hosts)
    if any("*" in host for host in hosts):
        raise ValueError(f"hosts are names, not patterns: got {hosts!r}")
    tokens = Tokens.generate() if tokens is None else tokens
    logins = Logins()
    state = DashboardState(source, events=events)
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
    app.state.tokens = tokens
    app.state.logins = logins
    # The last added runs first: the Host, then who calls and what, then the body's size.
    app.add_middleware(RequestLimits)
    app.add_middleware(AccessGuard, tokens=tokens, logins=logins)
    app.add_middleware(
        TrustedHostMiddleware, allowed_hosts=[*LOOPBACK_HOSTS, *hosts], www_redirect=False
    )
    install_error_handlers(app)
    for router in (*ROUTERS, history_router):
        app.include_router(router)
    app.mount("/static", StaticFiles(directory=static_dir), name="static")
    app.mount(DOCS_ASSETS_URL, StaticFiles(directory=DOCS_ASSETS_DIR), name="docs-assets")
    return app
