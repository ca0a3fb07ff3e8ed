"""``/api/sim/...``: pause, resume and speed of simulated time."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Path, Request

from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.schemas import SimActionIn, SimOut, SpeedIn
from dashboard.stopping import who_asked

__all__ = ["router"]

router = APIRouter(prefix="/api/sim", tags=["sim"], responses=ERROR_RESPONSES)


@router.post("/pause", response_model=SimOut)
async def pause(body: SimActionIn, state: State, request: Request) -> SimOut:
    """Stop simulated time (a fleet of AGV processes, which cannot stop its clock, stops
    its vehicles: ``stop`` in the answer follows them); ``reason`` and who asked go to the
    operator's log (body ``{}``: no reason given)."""
    state.source.pause()
    state.watch.paused(state.source.now, True, f"{body.reason} (asked by {who_asked(request)})")
    state.publish()
    return state.sim()


@router.post("/resume", response_model=SimOut)
async def resume(body: SimActionIn, state: State, request: Request) -> SimOut:
    """Let simulated time run again (the vehicles drive on); ``reason`` and who asked go
    to the operator's log."""
    state.source.resume()
    state.watch.paused(state.source.now, False, f"{body.reason} (asked by {who_asked(request)})")
    state.publish()
    return state.sim()


@router.post("/speed", response_model=SimOut)
async def speed(body: SpeedIn, state: State) -> SimOut:
    """Set simulated seconds per wall-clock second (0.01 <= factor <= 100)."""
    try:
        state.source.set_speed(body.factor)
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from exc
    state.publish()
    return state.sim()


@router.post("/{action}")
async def unknown_action(action: str = Path(max_length=64)) -> None:
    """Anything else under /api/sim is an error that names the valid actions."""
    raise HTTPException(404, f"unknown sim action {shown(action)} (known: pause, resume, speed)")
