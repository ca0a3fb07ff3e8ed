"""Request and response bodies of ``/api/blocks``: the closed parts of the floor."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["MAX_POLYGON_VERTICES", "BlockIn", "BlockOut", "BlocksOut"]

MAX_POLYGON_VERTICES = 200
"""Most vertices a closed polygon may have."""

Vertex = Annotated[list[float], Field(min_length=2, max_length=2)]


class BlockIn(BaseModel):
    """What to close: a segment or point by id, or a polygon by its vertices."""

    model_config = ConfigDict(extra="forbid", strict=True)

    kind: Literal["segment", "point", "polygon"]
    what: (
        Annotated[str, Field(min_length=1, max_length=128)]
        | Annotated[list[Vertex], Field(min_length=3, max_length=MAX_POLYGON_VERTICES)]
    ) = Field(
        description="the segment or point id; for a polygon its vertices [[x, y], ...] in "
        "layout metres",
        examples=["M4550>M3925"],
    )
    force: bool = Field(
        default=False, description="close even if it cuts every way out of some station"
    )
    reason: str = Field(default="asked over REST", min_length=1, max_length=200)


class BlockOut(BaseModel):
    """A block in force."""

    model_config = ConfigDict(extra="forbid")

    id: str = Field(description="b1, b2, ... in the order they were closed")
    kind: Literal["segment", "point", "polygon"]
    what: str | list[list[float]]
    points: list[str] = Field(description="the points it closes, sorted")
    segments: list[str] = Field(description="the segments it closes, sorted")
    positions: list[list[float]] = Field(
        description="the closed points' [x, y], in the order of points, for drawing"
    )
    polylines: list[list[list[float]]] = Field(
        description="the closed segments' lines [[x, y], ...], for drawing"
    )
    reason: str
    by: str = Field(description="who asked: the role and the client's address")
    since: float = Field(description="simulated seconds")


class BlocksOut(BaseModel):
    """Every block in force, and what they close together."""

    model_config = ConfigDict(extra="forbid")

    closable: bool = Field(description="whether this fleet can close parts of its floor")
    blocks: list[BlockOut]
    points: list[str] = Field(description="every closed point, sorted")
    segments: list[str] = Field(description="every closed segment, sorted")
