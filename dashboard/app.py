"""The dashboard server: REST API, the ``/ws/events`` feed, and the page.

``create_app(source)`` wraps any running fleet (``FleetSource``). While the app runs,
one asyncio task advances the fleet in real time and offers fresh states to the feed;
request handlers run on the same event loop, so they and the simulation never run at
the same time and need no locks. Endpoints and the feed format: ``docs/dashboard.md``.
"""

from __future__ import annotations

import asyncio
import hmac
import inspect
import json
import logging
import math
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, FastAPI, Header, HTTPException, Query, Request, WebSocket
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException

from dashboard import introspect
from dashboard.feed import (
    ClientFeed,
    FeedHub,
    FleetState,
    PolygonCache,
    SessionRecord,
    capture,
    layout_json,
)
from dashboard.poll import POLL_ROLE, RESPONDER_ROLE, PollResponder, poll_factory
from dashboard.schemas import (
    ErrorOut,
    GroupViewOut,
    LockOut,
    MetricsOut,
    NodeDetailOut,
    NodeOut,
    ParticipationOut,
    SessionDetailOut,
    SessionOut,
    SimOut,
    SpeedIn,
    StartSessionIn,
    StoppedOut,
    TaskIn,
    TaskOut,
    json_value,
)
from dashboard.source import FleetSource, InitiatorFactory
from objectplaces import Initiator, ObjectPlacesError, RoleActivator, Session, groups

__all__ = ["STATIC_DIR", "create_app"]

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
"""Where the page's files live (``static/`` beside the package)."""

log = logging.getLogger(__name__)

_ERRORS: dict[int | str, dict[str, Any]] = {
    code: {"model": ErrorOut} for code in (400, 401, 404, 409, 422)
}


@dataclass(slots=True)
class _ApiSession:
    """A session started through ``POST /api/sessions``."""

    node: str
    role: str
    handle: Session
    initiator: Initiator
    params: dict[str, Any]


@dataclass(slots=True)
class _Dashboard:
    """The app's state: the fleet, the feed's clients, sessions started over HTTP."""

    source: FleetSource
    tick_s: float
    hub: FeedHub = field(default_factory=FeedHub)
    wakers: dict[int, asyncio.Event] = field(default_factory=dict)
    api_sessions: dict[str, _ApiSession] = field(default_factory=dict)
    responders_on: set[str] = field(default_factory=set)
    layout: dict[str, Any] = field(default_factory=dict)
    polygons: PolygonCache = field(default_factory=PolygonCache)
    last_counters: dict[str, dict[str, Any]] | None = None

    def roles(self) -> dict[str, InitiatorFactory]:
        """Initiator roles startable over HTTP: the fleet's, and ``poll``."""
        roles: dict[str, InitiatorFactory] = dict(self.source.initiator_roles())
        roles[POLL_ROLE] = poll_factory
        return roles

    def node(self, node_id: str, *, status: int = 404) -> RoleActivator:
        """The node handle, or an HTTP error naming the unknown id."""
        nodes = self.source.nodes()
        if node_id not in nodes:
            known = ", ".join(sorted(nodes)[:8])
            more = ", ..." if len(nodes) > 8 else ""
            raise HTTPException(status, f"unknown node {node_id!r} (known: {known}{more})")
        return nodes[node_id]

    def ensure_responders(self) -> None:
        """Register the poll responder on every node that does not have it yet."""
        for node_id, node in self.source.nodes().items():
            if node_id in self.responders_on:
                continue
            node.set_participant_factory(RESPONDER_ROLE, _responder_factory(node))
            self.responders_on.add(node_id)

    def fixed_positions(self) -> dict[str, list[float]]:
        """Where the nodes that are not vehicles stand (stations), for session lines."""
        vehicles = {v.id for v in self.source.vehicles()}
        out: dict[str, list[float]] = {}
        for node_id, node in sorted(self.source.nodes().items()):
            pos = node.properties.get("position")
            if node_id in vehicles or not isinstance(pos, tuple | list) or len(pos) != 2:
                continue
            if all(isinstance(c, int | float) and math.isfinite(c) for c in pos):
                out[node_id] = [float(pos[0]), float(pos[1])]
        return out

    def sessions(self) -> dict[str, SessionRecord]:
        """Every live session on every node, by id; forgets API sessions that ended."""
        records: dict[str, SessionRecord] = {}
        for node_id, node in self.source.nodes().items():
            for rec in introspect.sessions_of(node_id, node):
                records[rec.session_id] = rec
        for sid in [s for s in self.api_sessions if s not in records]:
            del self.api_sessions[sid]
        for sid, api in self.api_sessions.items():
            records[sid] = _as_api_session(records[sid], api.role)
        return records

    def counters(self, *, fresh: bool = True) -> dict[str, dict[str, Any]]:
        """Per-node message and byte counters, by node id.

        Args:
            fresh: read the nodes; otherwise reuse the last reading when there is one
                (the feed sends counters only every half second anyway).
        """
        if fresh or self.last_counters is None:
            self.last_counters = {
                node_id: introspect.counters_of(node)
                for node_id, node in self.source.nodes().items()
            }
        return self.last_counters

    def capture(self, *, fresh_counters: bool = True) -> FleetState:
        """The fleet as the feed shows it now."""
        return capture(
            self.source,
            sessions=self.sessions(),
            nodes=self.counters(fresh=fresh_counters),
            cache=self.polygons,
        )

    def sim(self) -> SimOut:
        """The clock state."""
        s = self.source
        return SimOut(now=float(s.now), paused=bool(s.paused), speed=float(s.speed))

    def publish(self, *, fresh_counters: bool = True) -> None:
        """Offer the current state to every feed client and wake their senders."""
        if not len(self.hub):
            return
        self.hub.publish(self.capture(fresh_counters=fresh_counters))
        for event in self.wakers.values():
            event.set()

    async def run(self) -> None:
        """Advance the fleet in real time and feed the clients, until cancelled."""
        loop = asyncio.get_running_loop()
        last = loop.time()
        last_publish = -math.inf
        last_check = -math.inf
        last_counters = -math.inf
        while True:
            await asyncio.sleep(self.tick_s)
            now = loop.time()
            # A stalled loop must not make the fleet jump: at most 0.1 s per step.
            elapsed, last = min(now - last, 0.1), now
            if not self.source.paused:
                try:
                    self.source.advance(elapsed * self.source.speed)
                except Exception:
                    log.exception("the fleet failed to advance; pausing it")
                    self.source.pause()
            if now - last_check >= 1.0:
                last_check = now
                self.ensure_responders()
            if now - last_publish >= 0.05:
                last_publish = now
                fresh = now - last_counters >= 0.5
                if fresh:
                    last_counters = now
                self.publish(fresh_counters=fresh)


def _responder_factory(node: RoleActivator) -> Callable[[], PollResponder]:
    return lambda: PollResponder(lambda: node.properties)


def _log_sender_end(task: asyncio.Future[None]) -> None:
    if not task.cancelled() and task.exception() is not None:
        # A client that vanishes mid-send ends here; it is normal, not an error.
        log.debug("feed sender ended: %r", task.exception())


def _as_api_session(rec: SessionRecord, role: str) -> SessionRecord:
    # The node knows the role's class; the API knows the name it was started under.
    return SessionRecord(
        session_id=rec.session_id,
        node=rec.node,
        role=role,
        participant_role=rec.participant_role,
        members=rec.members,
        started_at=rec.started_at,
        definition=rec.definition,
        via_api=True,
    )


def _session_out(rec: SessionRecord, now: float) -> dict[str, Any]:
    return {
        "id": rec.session_id,
        "node": rec.node,
        "role": rec.role,
        "participant_role": rec.participant_role,
        "members": sorted(rec.members),
        "started_at": rec.started_at,
        "age_s": max(0.0, now - rec.started_at),
        "definition": json_value(rec.definition),
        "via_api": rec.via_api,
    }


def _validation_message(exc: RequestValidationError) -> tuple[int, str]:
    parts: list[str] = []
    for err in exc.errors():
        if err.get("type") == "json_invalid":
            ctx = err.get("ctx") or {}
            return 400, f"malformed JSON body: {ctx.get('error', err.get('msg'))}"
        where = ".".join(str(p) for p in err.get("loc", ()) if p != "body") or "body"
        parts.append(f"{where}: {err.get('msg')}")
    return 422, "; ".join(parts) or "invalid request"


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
        The FastAPI app (OpenAPI at ``/docs``).
    """
    dash = _Dashboard(source=source, tick_s=tick_s)
    dash.layout = layout_json(source.layout_view())
    dash.ensure_responders()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # A fleet of separate processes starts and stops with the app (optional hooks).
        start, stop = getattr(source, "start", None), getattr(source, "stop", None)
        if inspect.iscoroutinefunction(start):
            await start()
        try:
            async with asyncio.TaskGroup() as tasks:
                runner = tasks.create_task(dash.run())
                try:
                    yield
                finally:
                    runner.cancel()
        finally:
            if inspect.iscoroutinefunction(stop):
                await stop()

    app = FastAPI(
        title="ObjectPlaces dashboard",
        summary="Live fleet: nodes, sessions, groups, locks; start sessions and tasks.",
        version="0.1.0",
        lifespan=lifespan,
    )
    app.state.dashboard = dash

    @app.exception_handler(RequestValidationError)
    async def on_invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        status, message = _validation_message(exc)
        return JSONResponse({"detail": message}, status_code=status)

    @app.exception_handler(StarletteHTTPException)
    async def on_http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        detail = exc.detail if isinstance(exc.detail, str) else json.dumps(exc.detail)
        return JSONResponse({"detail": detail}, status_code=exc.status_code, headers=exc.headers)

    def check_token(authorization: Annotated[str | None, Header()] = None) -> None:
        if token is None:
            return
        scheme, _, given = (authorization or "").partition(" ")
        if scheme.lower() != "bearer" or not hmac.compare_digest(given.encode(), token.encode()):
            raise HTTPException(
                401,
                "this server needs a token for changes: send 'Authorization: Bearer <token>'",
                headers={"WWW-Authenticate": "Bearer"},
            )

    mutating = [Depends(check_token)]

    # ---- nodes ------------------------------------------------------------------------

    def node_out(node_id: str, node: RoleActivator) -> dict[str, Any]:
        counters = introspect.counters_of(node)
        return {
            "id": node_id,
            "properties": json_value(dict(introspect.properties_of(node))),
            "initiated": len(introspect.sessions_of(node_id, node)),
            "participating": len(introspect.participations_of(node)),
            "messages": int(counters.get("messages", 0)),
            "bytes": int(counters.get("bytes", 0)),
        }

    @app.get("/api/nodes", response_model=list[NodeOut], tags=["nodes"])
    def list_nodes() -> list[dict[str, Any]]:
        """Every node: its own properties, role counts and traffic."""
        nodes = source.nodes()
        return [node_out(node_id, nodes[node_id]) for node_id in sorted(nodes)]

    @app.get(
        "/api/nodes/{node_id}", response_model=NodeDetailOut, responses=_ERRORS, tags=["nodes"]
    )
    def get_node(node_id: str) -> dict[str, Any]:
        """One node in full: sessions it initiated, roles it plays, counters, its view."""
        node = dash.node(node_id)
        sessions = dash.sessions()
        out = node_out(node_id, node)
        out["sessions"] = [
            _session_out(sessions.get(r.session_id, r), source.now)
            for r in introspect.sessions_of(node_id, node)
        ]
        out["participations"] = [
            ParticipationOut(**p).model_dump() for p in introspect.participations_of(node)
        ]
        out["stats"] = json_value(dict(introspect.counters_of(node, full=True)))
        out["view"] = {k: json_value(dict(v)) for k, v in introspect.view_of(node).items()}
        return out

    # ---- sessions ---------------------------------------------------------------------

    def session_detail(sid: str) -> dict[str, Any]:
        rec = dash.sessions().get(sid)
        if rec is None:
            raise HTTPException(404, f"unknown session {sid!r} (it never existed or has ended)")
        out = _session_out(rec, source.now)
        api = dash.api_sessions.get(sid)
        out["params"] = json_value(api.params) if api else {}
        report = getattr(api.initiator, "detail", None) if api else None
        out["detail"] = json_value(report()) if callable(report) else None
        return out

    @app.get("/api/sessions", response_model=list[SessionOut], tags=["sessions"])
    def list_sessions() -> list[dict[str, Any]]:
        """Every live session on every node, oldest first."""
        records = sorted(dash.sessions().values(), key=lambda r: (r.started_at, r.session_id))
        return [_session_out(r, source.now) for r in records]

    @app.get(
        "/api/sessions/{session_id}",
        response_model=SessionDetailOut,
        responses=_ERRORS,
        tags=["sessions"],
    )
    def get_session(session_id: str) -> dict[str, Any]:
        """One session, with its initiator's report (a poll's answers). Session ids
        contain ``#``: encode it as ``%23`` in the path."""
        return session_detail(session_id)

    @app.post(
        "/api/sessions",
        status_code=201,
        response_model=SessionDetailOut,
        responses=_ERRORS,
        dependencies=mutating,
        tags=["sessions"],
    )
    def start_session(body: StartSessionIn) -> dict[str, Any]:
        """Start a session on a node with a registered initiator role."""
        node = dash.node(body.node, status=422)
        roles = dash.roles()
        factory = roles.get(body.role)
        if factory is None:
            known = ", ".join(sorted(roles))
            raise HTTPException(422, f"unknown initiator role {body.role!r} (known: {known})")
        try:
            definition = groups.definition_from_json(body.definition)
        except ObjectPlacesError as exc:
            raise HTTPException(422, f"invalid group definition: {exc}") from exc
        try:
            initiator = factory(body.params)
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc
        try:
            handle = node.start_interaction(initiator, definition, body.participant_role)
        except ObjectPlacesError as exc:
            raise HTTPException(422, f"cannot start the session: {exc}") from exc
        sid = str(handle.session_id)
        dash.api_sessions[sid] = _ApiSession(
            node=body.node, role=body.role, handle=handle, initiator=initiator, params=body.params
        )
        return session_detail(sid)

    @app.delete(
        "/api/sessions/{session_id}",
        response_model=StoppedOut,
        responses=_ERRORS,
        dependencies=mutating,
        tags=["sessions"],
    )
    def stop_session(session_id: str) -> StoppedOut:
        """Stop a session started through the API (the fleet's own are not ours to stop)."""
        api = dash.api_sessions.get(session_id)
        if api is None:
            if session_id in dash.sessions():
                raise HTTPException(
                    409,
                    f"session {session_id!r} belongs to the fleet; "
                    "only sessions started through POST /api/sessions can be stopped",
                )
            raise HTTPException(404, f"unknown session {session_id!r}")
        del dash.api_sessions[session_id]
        try:
            dash.node(api.node).stop_interaction(api.handle)
        except ObjectPlacesError as exc:
            raise HTTPException(404, f"session {session_id!r} has already ended") from exc
        return StoppedOut(id=session_id)

    # ---- groups, locks, tasks, metrics ------------------------------------------------

    @app.get("/api/groups/view", response_model=GroupViewOut, responses=_ERRORS, tags=["groups"])
    def view_group(
        definition: Annotated[
            str,
            Query(
                description="a declarative group definition as JSON",
                examples=['{"type": "within", "distance": 20}'],
            ),
        ],
        node: Annotated[
            str | None,
            Query(description="the would-be initiator's node id (default: the observer)"),
        ] = None,
    ) -> GroupViewOut:
        """Which nodes a definition selects from a node's point of view, without a session."""
        node = source.observer_id if node is None else node
        handle = dash.node(node)
        try:
            obj = json.loads(definition)
        except json.JSONDecodeError as exc:
            raise HTTPException(400, f"definition is not valid JSON: {exc}") from exc
        try:
            defn = groups.definition_from_json(obj)
        except ObjectPlacesError as exc:
            raise HTTPException(422, f"invalid group definition: {exc}") from exc
        members = handle.view_group(defn)
        return GroupViewOut(node=node, definition=defn.to_json(), members=sorted(members))

    @app.get("/api/locks", response_model=list[LockOut], tags=["fleet"])
    def list_locks() -> list[dict[str, Any]]:
        """Every AGV's locked and requested hull projections."""
        out = []
        for vid, rec in sorted(capture(source, sessions={}, nodes={}).vehicles.items()):
            out.append(
                {
                    "vehicle": vid,
                    "status": rec["status"],
                    "hull_length": rec["hull_length"],
                    "locked": rec["locked"],
                    "requested": rec["requested"],
                }
            )
        return out

    @app.post(
        "/api/tasks",
        status_code=201,
        response_model=TaskOut,
        responses=_ERRORS,
        dependencies=mutating,
        tags=["fleet"],
    )
    def create_task(body: TaskIn) -> TaskOut:
        """Create a transport task at a station (starts its task-assignment session)."""
        try:
            task_id = source.create_task(body.station)
        except LookupError as exc:
            known = ", ".join(s["id"] for s in dash.layout["stations"])
            raise HTTPException(404, f"unknown station {body.station!r} (known: {known})") from exc
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc
        return TaskOut(task_id=str(task_id), station=body.station)

    @app.get("/api/metrics", response_model=MetricsOut, tags=["fleet"])
    def get_metrics() -> MetricsOut:
        """Fleet figures (tasks, messages, safety) and the clock."""
        metrics = {
            str(k): (float(v) if math.isfinite(float(v)) else None)
            for k, v in source.metrics().items()
        }
        return MetricsOut(sim=dash.sim(), metrics=metrics)

    # ---- simulation controls ------------------------------------------------------------

    @app.post("/api/sim/pause", response_model=SimOut, dependencies=mutating, tags=["sim"])
    def pause() -> SimOut:
        """Stop simulated time."""
        source.pause()
        dash.publish()
        return dash.sim()

    @app.post("/api/sim/resume", response_model=SimOut, dependencies=mutating, tags=["sim"])
    def resume() -> SimOut:
        """Let simulated time run again."""
        source.resume()
        dash.publish()
        return dash.sim()

    @app.post(
        "/api/sim/speed",
        response_model=SimOut,
        responses=_ERRORS,
        dependencies=mutating,
        tags=["sim"],
    )
    def speed(body: SpeedIn) -> SimOut:
        """Set simulated seconds per wall-clock second (0 < factor <= 100)."""
        try:
            source.set_speed(body.factor)
        except ValueError as exc:
            raise HTTPException(422, str(exc)) from exc
        dash.publish()
        return dash.sim()

    @app.post("/api/sim/{action}", responses=_ERRORS, dependencies=mutating, tags=["sim"])
    def unknown_action(action: str) -> None:
        """Anything else under /api/sim is an error that names the valid actions."""
        raise HTTPException(404, f"unknown sim action {action!r} (known: pause, resume, speed)")

    # ---- the feed and the page ------------------------------------------------------------

    @app.websocket("/ws/events")
    async def events(websocket: WebSocket) -> None:
        """A snapshot, then deltas at most 20 times a second (docs/dashboard.md)."""
        await websocket.accept()
        loop = asyncio.get_running_loop()
        feed = ClientFeed(dict(dash.layout, nodes=dash.fixed_positions()))
        wake = asyncio.Event()
        handle = dash.hub.add(feed)
        dash.wakers[handle] = wake
        feed.offer(dash.capture())

        async def send() -> None:
            while True:
                wait = feed.delay(loop.time())
                if wait is None:
                    await wake.wait()
                    wake.clear()
                    continue
                if wait > 0:
                    await asyncio.sleep(wait)
                message = feed.take(loop.time())
                if message is not None:
                    await websocket.send_text(json.dumps(message, separators=(",", ":")))

        # The sender lives exactly as long as this handler: it is cancelled in
        # ``finally`` without awaiting it, so a cancellation arriving from the server
        # (shutdown, a test client closing) is never swallowed or re-raised twice.
        sender = asyncio.ensure_future(send())
        sender.add_done_callback(_log_sender_end)
        try:
            while True:
                msg = await websocket.receive()
                if msg["type"] == "websocket.disconnect":
                    break
        finally:
            sender.cancel()
            dash.hub.remove(handle)
            dash.wakers.pop(handle, None)

    app.mount("/static", StaticFiles(directory=static_dir), name="static")

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(static_dir / "index.html")

    return app
