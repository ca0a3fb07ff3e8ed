"""A vehicle's own log of where it was and what it held, and the safety check over many.

Across hosts no process sees every vehicle at every moment: the control process hears
them late and may be down. So each AGV process writes its own trace (``--trace F``),
JSON lines stamped with the host's wall clock (the hosts of one test share a clock):

- ``{"t", "k": "size", "m": [length, width]}`` once;
- ``{"t", "k": "pose", "p": [x, y, heading]}`` every few steps and whenever it stops;
- ``{"t", "k": "locks", "w": WKT}`` at the very moment its lock book changes (a
  tuplespace notification): the union of its locked projections, exactly;
- ``{"t", "k": "outside", "m": metres}`` whenever the metres it drove with its hull
  not inside its own locked floor grow (it checks every control step);
- ``{"t", "k": "cut", "v": true|false}`` when it is cut off from its fleet, and back
  (``agv_app.vehicle.isolation``).

:func:`check_traces` merges the traces after a run: two vehicles' locks overlapping at
any moment (their lock changes in time order), two hulls meeting (poses interpolated),
and the metres each drove outside its locked floor, which must all be zero. Lock
changes are written when they happen and a lock is granted only after the release that
made room for it has reached the grantee, so a correct fleet shows no overlap, however
late the files are read.
"""

from __future__ import annotations

import bisect
import json
import math
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import shapely

from agv_app.geometry import DEFAULT_OVERLAP_TOLERANCE_M2, Area, Pose
from agv_app.geometry.projection import hull
from agv_app.vehicle.controller import AgvController
from tuplespace import ANY

__all__ = ["SafetyReport", "VehicleTrace", "check_traces"]

_POSE_EVERY_S = 0.1
_STANDING_POSE_EVERY_S = 1.0
_OUTSIDE_TOLERANCE_M2 = 0.01
"""Hull area outside the locked floor that counts (floating-point slivers do not)."""


class VehicleTrace:
    """Writes one AGV's trace to ``path`` (appending: a restarted process continues it).

    Args:
        agv: the AGV component.
        path: the file.
        clock: wall-clock seconds (shared by the processes of one run).
    """

    def __init__(self, agv: AgvController, path: Path, *, clock: Any = time.time) -> None:
        self.agv = agv
        self._clock = clock
        self._file: IO[str] = path.open("a", buffering=1)
        self._next_pose = 0.0
        self._last_xy: tuple[float, float] | None = None
        self._cut = False
        self.outside_m = 0.0
        """Metres driven with the hull not inside the AGV's own locked floor."""
        self._write("size", m=[agv.spec.length_m, agv.spec.width_m])
        space = agv.node.space
        self._watches = [
            space.notify(("lock", ANY, ANY, ANY), self._locks_changed, on=kind)
            for kind in ("out", "in")
        ]
        self._locks_changed("out", ())

    def _write(self, kind: str, **fields: Any) -> None:
        self._file.write(json.dumps({"t": self._clock(), "k": kind, **fields}) + "\n")

    def _locks_changed(self, _kind: str, _tuple: tuple[Any, ...]) -> None:
        locks, _ = self.agv.areas()
        self._write("locks", w=Area.union_of(locks).geom.wkt)

    def step(self) -> None:
        """After a control step: the pose now and then, the metres outside the locks."""
        agv = self.agv
        pose = agv.vehicle.pose()
        now = self._clock()
        if self._last_xy is not None:
            moved = math.hypot(pose.x - self._last_xy[0], pose.y - self._last_xy[1])
            if moved > 0.0:
                locks, _ = agv.areas()
                outside = agv.vehicle.hull().difference(Area.union_of(locks)).area_m2
                if outside > _OUTSIDE_TOLERANCE_M2:
                    self.outside_m += moved
                    self._write("outside", m=self.outside_m)
        self._last_xy = (pose.x, pose.y)
        if agv.cut_off.cut_off != self._cut:
            self._cut = agv.cut_off.cut_off
            self._write("cut", v=self._cut)
        if now >= self._next_pose:
            # Standing, a pose a second says where it stands (poses are interpolated).
            moving = agv.vehicle.speed > 0.0
            self._next_pose = now + (_POSE_EVERY_S if moving else _STANDING_POSE_EVERY_S)
            self._write("pose", p=[pose.x, pose.y, pose.heading_rad])

    def close(self) -> None:
        """Write the last pose and close the file."""
        for watch in self._watches:
            watch.cancel()
        pose = self.agv.vehicle.pose()
        self._write("pose", p=[pose.x, pose.y, pose.heading_rad])
        self._file.close()


@dataclass
class SafetyReport:
    """What the merged traces show."""

    collisions: int = 0
    lock_overlaps: int = 0
    outside_m: dict[str, float] = field(default_factory=dict)
    vehicles: int = 0
    details: list[str] = field(default_factory=list)

    @property
    def safe(self) -> bool:
        """No collision, no overlap, not a centimetre outside a vehicle's locked floor."""
        return not (self.collisions or self.lock_overlaps or any(self.outside_m.values()))


@dataclass
class _Timeline:
    size: tuple[float, float] = (2.0, 1.0)
    pose_t: list[float] = field(default_factory=list)
    poses: list[tuple[float, float, float]] = field(default_factory=list)
    locks: list[tuple[float, Any]] = field(default_factory=list)
    outside_m: float = 0.0

    def pose_at(self, t: float) -> tuple[float, float, float] | None:
        i = bisect.bisect_right(self.pose_t, t)
        if i == 0:
            return None
        if i == len(self.pose_t):
            return self.poses[-1]
        (t0, t1), (a, b) = (self.pose_t[i - 1], self.pose_t[i]), (self.poses[i - 1], self.poses[i])
        w = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
        return (a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), b[2] if w > 0.5 else a[2])


def _read(path: Path) -> _Timeline:
    line = _Timeline()
    with path.open() as handle:
        for text in handle:
            try:
                record = json.loads(text)
            except ValueError:
                continue  # a line cut short by a killed process
            kind, t = record.get("k"), float(record.get("t", 0.0))
            if kind == "pose":
                line.pose_t.append(t)
                line.poses.append(tuple(record["p"]))
            elif kind == "locks":
                line.locks.append((t, shapely.from_wkt(record["w"])))
            elif kind == "outside":
                line.outside_m = max(line.outside_m, float(record["m"]))
            elif kind == "size":
                line.size = (float(record["m"][0]), float(record["m"][1]))
    order = sorted(range(len(line.pose_t)), key=line.pose_t.__getitem__)
    line.pose_t = [line.pose_t[i] for i in order]
    line.poses = [line.poses[i] for i in order]
    line.locks.sort(key=lambda item: item[0])
    return line


def check_traces(paths: Iterable[Path], *, sample_s: float = 0.1) -> SafetyReport:
    """Merge the traces of one run (a file per vehicle, named ``ID.jsonl``) and count
    what must never happen."""
    lines = {path.stem: _read(path) for path in sorted(paths)}
    report = SafetyReport(vehicles=len(lines))
    report.outside_m = {v: round(line.outside_m, 3) for v, line in lines.items()}
    report.lock_overlaps = _lock_overlaps(lines, report.details)
    report.collisions = _collisions(lines, sample_s, report.details)
    return report


def _lock_overlaps(lines: dict[str, _Timeline], details: list[str]) -> int:
    # In time order; one vehicle's changes at one instant in the order it wrote them.
    events = sorted(
        ((t, v, geom) for v, line in lines.items() for t, geom in line.locks),
        key=lambda event: (event[0], event[1]),
    )
    held: dict[str, Any] = {}
    found: set[tuple[str, str]] = set()
    count = 0
    for t, vehicle, geom in events:
        held[vehicle] = geom
        for other, theirs in held.items():
            if other == vehicle or geom.is_empty or theirs.is_empty:
                continue
            overlap = geom.intersection(theirs).area
            pair = (min(vehicle, other), max(vehicle, other))
            if overlap > DEFAULT_OVERLAP_TOLERANCE_M2:
                if pair not in found:
                    found.add(pair)
                    count += 1
                    details.append(
                        f"t={t:.3f}: locks of {pair[0]} and {pair[1]} overlap {overlap:.3f} m2"
                    )
            else:
                found.discard(pair)
    return count


def _collisions(lines: dict[str, _Timeline], sample_s: float, details: list[str]) -> int:
    starts = [line.pose_t[0] for line in lines.values() if line.pose_t]
    ends = [line.pose_t[-1] for line in lines.values() if line.pose_t]
    if not starts:
        return 0
    t, end = min(starts), max(ends)
    touching: set[tuple[str, str]] = set()
    count = 0
    while t <= end:
        hulls: list[tuple[str, Area, float, float, float]] = []
        for vehicle, line in lines.items():
            pose = line.pose_at(t)
            if pose is not None:
                length, width = line.size
                shape = hull(Pose(*pose), length=length, width=width)
                hulls.append((vehicle, shape, pose[0], pose[1], math.hypot(length, width) / 2))
        now = _meeting(hulls)
        for pair in sorted(now - touching):
            count += 1
            details.append(f"t={t:.3f}: hulls of {pair[0]} and {pair[1]} meet")
        touching = now
        t += sample_s
    return count


def _meeting(hulls: Sequence[tuple[str, Area, float, float, float]]) -> set[tuple[str, str]]:
    """Pairs of vehicles whose hulls overlap; hulls ``(id, area, x, y, half diagonal)``."""
    pairs: set[tuple[str, str]] = set()
    for i, (a, ha, xa, ya, ra) in enumerate(hulls):
        for b, hb, xb, yb, rb in hulls[i + 1 :]:
            if math.hypot(xa - xb, ya - yb) <= ra + rb and ha.overlaps(hb):
                pairs.add((min(a, b), max(a, b)))
    return pairs
