"""Closing parts of the floor: ``GET``/``POST /api/blocks``, ``DELETE /api/blocks/{id}``.

An operator closes a segment, a point or a polygon (:mod:`agv_app.fleet.blocks`); the
vehicles route around it, one inside leaves by the shortest way out, and orders that
need it wait, saying why. Only the operator may change them (``dashboard.guard``); each
change is checked whole before anything is applied, and logged with who asked and why.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, HTTPException, Path, Request

from agv_app.fleet.blocks import Block, CutsOff, FloorBlocks, UnknownBlock
from agv_app.layout.blocked import UnknownElement
from agv_app.layout.elements import LayoutError
from dashboard.blocks_schemas import BlockIn, BlockOut, BlocksOut
from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.state import DashboardState
from dashboard.stopping import who_asked

__all__ = ["block_out", "blocks_of", "router"]

router = APIRouter(prefix="/api/blocks", tags=["operate"], responses=ERROR_RESPONSES)

BlockId = Annotated[str, Path(min_length=1, max_length=64)]


def blocks_of(source: object) -> FloorBlocks | None:
    """The closed parts of the fleet's floor, if it can close any."""
    blocks = getattr(source, "blocks", None)
    return blocks if isinstance(blocks, FloorBlocks) else None


def _blocks(state: DashboardState) -> FloorBlocks:
    blocks = blocks_of(state.source)
    if blocks is None:
        raise HTTPException(409, "this fleet cannot close parts of its floor")
    return blocks


def block_out(blocks: FloorBlocks, block: Block) -> BlockOut:
    """One block as the API shows it."""
    layout = blocks.layout
    points, segments = sorted(block.closed.points), sorted(block.closed.segments)
    return BlockOut(
        id=block.id,
        kind=block.kind,
        what=block.what if isinstance(block.what, str) else [list(v) for v in block.what],
        points=points,
        segments=segments,
        positions=[list(layout.point(p).xy) for p in points],
        polylines=[[list(xy) for xy in layout.segment_coords(s)] for s in segments],
        reason=block.reason,
        by=block.by,
        since=block.since,
    )


def _all(blocks: FloorBlocks) -> BlocksOut:
    ways = blocks.ways
    return BlocksOut(
        closable=True,
        blocks=[block_out(blocks, b) for b in blocks.blocks()],
        points=[] if ways is None else sorted(ways.closed.points),
        segments=[] if ways is None else sorted(ways.closed.segments),
    )


def _log(state: DashboardState, text: str, *, warning: bool) -> None:
    state.events.record(float(state.source.now), "warning" if warning else "info", "floor", text)
    state.publish()


def _named(block: Block) -> str:
    what = block.what if isinstance(block.what, str) else f"{len(block.what)} vertices"
    return f"{block.id} ({block.kind} {what})"


@router.get("", response_model=BlocksOut)
async def list_blocks(state: State) -> BlocksOut:
    """The blocks in force, oldest first, and every point and segment they close
    (none, and ``closable`` false, for a fleet that cannot close any)."""
    blocks = blocks_of(state.source)
    if blocks is None:
        return BlocksOut(closable=False, blocks=[], points=[], segments=[])
    return _all(blocks)


@router.post("", response_model=BlockOut, status_code=201)
async def close_block(body: BlockIn, state: State, request: Request) -> BlockOut:
    """Close a segment, a point or a polygon. 404 names the known segments or points;
    422 names the stations it would cut off from the rest of the floor (``force``:
    close anyway), or says what is wrong with a polygon."""
    blocks = _blocks(state)
    if (body.kind == "polygon") == isinstance(body.what, str):
        want = "a list of [x, y] vertices" if body.kind == "polygon" else "an id"
        raise HTTPException(422, f"what: a {body.kind} is given by {want}")
    what = body.what if isinstance(body.what, str) else [(v[0], v[1]) for v in body.what]
    who = who_asked(request)
    try:
        block = blocks.close(
            body.kind,
            what,
            force=body.force,
            reason=body.reason,
            by=who,
            now=float(state.source.now),
        )
    except UnknownElement as exc:
        raise HTTPException(404, str(exc).replace(repr(exc.name), shown(exc.name))) from exc
    except (CutsOff, LayoutError) as exc:
        raise HTTPException(422, str(exc)) from exc
    forced = " (forced)" if body.force else ""
    _log(state, f"{_named(block)} closed{forced} by {who}: {body.reason}", warning=True)
    return block_out(blocks, block)


@router.delete("/{block_id}", response_model=BlockOut)
async def reopen_block(block_id: BlockId, state: State, request: Request) -> BlockOut:
    """Reopen a block; 404 names the blocks in force."""
    blocks = _blocks(state)
    try:
        block = blocks.reopen(block_id)
    except UnknownBlock as exc:
        known = ", ".join(exc.known[:10]) or "none"
        raise HTTPException(404, f"unknown block {shown(block_id)} (known: {known})") from exc
    _log(state, f"{_named(block)} reopened by {who_asked(request)}", warning=False)
    return block_out(blocks, block)
