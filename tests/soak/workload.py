"""The seeded generator of one run: a random set of nodes, network, and list of steps.

A run is three *chaos* phases (moves, sessions started and stopped, messages and bursts,
joins, leaves, crashes, restarts, partitions and heals, link trouble, a hostile peer),
each followed by a *calm* phase (the network heals, nothing moves, nothing is injected)
that ends in a checkpoint, and a final phase that stops every session and waits for the
network to forget them. The same seed always gives the same scenario, step for step;
the generator tracks which nodes live and which sessions run, so every step is valid.
"""

from __future__ import annotations

import dataclasses
import random
from dataclasses import dataclass, field

from tests.soak.hostile import forge

__all__ = [
    "HOSTILE",
    "ROLE_NAMES",
    "Crash",
    "Heal",
    "InitiatorSends",
    "Inject",
    "Join",
    "Leave",
    "Link",
    "Move",
    "ParticipantSends",
    "Partition",
    "Placement",
    "Restart",
    "Scenario",
    "Settle",
    "Start",
    "Step",
    "Stop",
    "StopAll",
    "Wait",
    "generate",
]

HOSTILE = "x-hostile"
"""The hostile peer's id: never a node of the network, only a source of injected frames."""
ROLE_NAMES = ("probe", "decoy")
"""Participant role names: sessions ask for one; nodes register some, one or none."""


@dataclass(frozen=True, slots=True)
class Placement:
    """Where a node is and what it publishes."""

    x: float
    y: float
    hull: float
    team: str


@dataclass(frozen=True, slots=True)
class Move:
    """``node`` publishes a new placement."""

    node: str
    to: Placement


@dataclass(frozen=True, slots=True)
class Start:
    """``node`` starts session ``label`` asking for ``role`` over ``definition``.

    ``definition`` is ("overlap",), ("within", d), ("near", x, y, d), ("overlap_team",
    team) or ("within_or_team", d, team); the runner builds the declarative definition.
    """

    node: str
    label: int
    definition: tuple[object, ...]
    role: str
    faulty: bool = False


@dataclass(frozen=True, slots=True)
class Stop:
    """The initiator of session ``label`` stops it."""

    label: int


@dataclass(frozen=True, slots=True)
class InitiatorSends:
    """The initiator of ``label`` sends ``count`` messages to each of its members."""

    label: int
    count: int


@dataclass(frozen=True, slots=True)
class ParticipantSends:
    """Every participant role active on ``node`` sends ``count`` messages."""

    node: str
    count: int


@dataclass(frozen=True, slots=True)
class Wait:
    """Let ``seconds`` of virtual time pass."""

    seconds: float


@dataclass(frozen=True, slots=True)
class Crash:
    """``node`` stops at once, saying nothing."""

    node: str


@dataclass(frozen=True, slots=True)
class Leave:
    """``node`` leaves gracefully."""

    node: str


@dataclass(frozen=True, slots=True)
class Restart:
    """``node``, crashed or gone, comes back as a new run of itself."""

    node: str
    at: Placement


@dataclass(frozen=True, slots=True)
class Join:
    """A node never seen before joins."""

    node: str
    at: Placement


@dataclass(frozen=True, slots=True)
class Partition:
    """The network splits into ``groups`` (nodes named in none form one more group)."""

    groups: tuple[tuple[str, ...], ...]


@dataclass(frozen=True, slots=True)
class Heal:
    """Every partition heals."""


@dataclass(frozen=True, slots=True)
class Rest:
    """``node`` says it is at rest (``on``) or no longer (docs/protocol.md §2)."""

    node: str
    on: bool


@dataclass(frozen=True, slots=True)
class Link:
    """The link between ``a`` and ``b`` changes, both ways."""

    a: str
    b: str
    loss: float
    duplicate: float
    reorder: float


@dataclass(frozen=True, slots=True)
class Inject:
    """The hostile peer sends ``data`` (a forgery of ``kind``) to ``target``."""

    target: str
    kind: str
    data: bytes = field(repr=False)


@dataclass(frozen=True, slots=True)
class StopAll:
    """Every live session is stopped by its initiator."""


@dataclass(frozen=True, slots=True)
class Settle:
    """Quiescence: wait (up to the runner's bound) and check what must hold after it.

    ``final``: every session was stopped; nothing of them may remain anywhere.
    """

    final: bool = False


Step = (
    Move
    | Start
    | Stop
    | InitiatorSends
    | ParticipantSends
    | Wait
    | Crash
    | Leave
    | Restart
    | Join
    | Partition
    | Heal
    | Link
    | Rest
    | Inject
    | StopAll
    | Settle
)


@dataclass(frozen=True, slots=True)
class Scenario:
    """Everything one seed decides: the nodes, the network, the steps."""

    seed: int
    initial: tuple[tuple[str, Placement], ...]
    roles: dict[str, frozenset[str]]
    delay: float
    jitter: float
    loss: float
    duplicate: float
    reorder: float
    cell_size: float
    property_interval: float | None
    failure_timeout: float
    interest_radius: float | None
    arena: float
    steps: tuple[Step, ...]
    beat_interval: float | None = None
    rest_beat_interval: float | None = None


class _Builder:
    """Generates steps while tracking what lives, so every step is valid."""

    def __init__(
        self,
        rng: random.Random,
        scenario_ids: list[str],
        arena: float,
        rest_rng: random.Random | None = None,
        near_rng: random.Random | None = None,
    ) -> None:
        self.rng = rng
        # Draws of its own for nodes coming to rest and leaving it: the other steps of
        # a seed are the same with beats and rest as without.
        self.rest_rng = rest_rng
        # And for groups about a fixed point: a seed's other steps are as before them.
        self.near_rng = near_rng
        self.arena = arena
        self.live: list[str] = []
        self.gone: list[str] = []  # crashed or left: may restart
        self.spare: list[str] = scenario_ids
        self.placements: dict[str, Placement] = {}
        self.labels: dict[int, str] = {}  # live session label -> initiator node
        self.next_label = 1
        self.steps: list[Step] = []
        self.partitioned = False
        self.scoped = False

    def placement(self) -> Placement:
        rng = self.rng
        return Placement(
            round(rng.uniform(0, self.arena), 3),
            round(rng.uniform(0, self.arena), 3),
            round(rng.uniform(0.5, 3.0), 3),
            rng.choice(["red", "blue"]),
        )

    def moved(self, node: str) -> Placement:
        rng = self.rng
        old = self.placements[node]
        if rng.random() < 0.3:
            new = self.placement()
        else:
            x = min(self.arena, max(0.0, old.x + rng.uniform(-2.0, 2.0)))
            y = min(self.arena, max(0.0, old.y + rng.uniform(-2.0, 2.0)))
            hull = old.hull if rng.random() < 0.85 else round(rng.uniform(0.5, 3.0), 3)
            team = old.team if rng.random() < 0.9 else rng.choice(["red", "blue"])
            new = Placement(round(x, 3), round(y, 3), hull, team)
        self.placements[node] = new
        return new

    def add(self, step: Step) -> None:
        self.steps.append(step)

    def drop_sessions_of(self, node: str) -> None:
        for label in [label for label, owner in self.labels.items() if owner == node]:
            del self.labels[label]

    def definition(self) -> tuple[object, ...]:
        rng = self.rng
        team = rng.choice(["red", "blue"])
        d = round(rng.uniform(2.0, 10.0), 3)
        choices: list[tuple[object, ...]] = [("overlap",), ("within", d), ("overlap_team", team)]
        if not self.scoped:
            # A disjunction has no reach: only full dissemination sees every candidate.
            choices.append(("within_or_team", d, team))
        choice = rng.choice(choices)
        near = self.near_rng
        if choice[0] == "within" and not self.scoped and near is not None and near.random() < 0.5:
            # About a point anywhere in the arena, which a scoped initiator may not hear.
            x, y = (round(near.uniform(0, self.arena), 3) for _ in range(2))
            return ("near", x, y, d)
        return choice

    def chaos_step(self) -> None:
        rng = self.rng
        kinds = {
            "move": 30,
            "start": 8 if len(self.labels) < 6 else 0,
            "stop": 5 if self.labels else 0,
            "isend": 15 if self.labels else 0,
            "psend": 15,
            "wait": 12,
            "crash": 3 if len(self.live) > 2 else 0,
            "leave": 2 if len(self.live) > 2 else 0,
            "restart": 3 if self.gone else 0,
            "join": 2 if self.spare else 0,
            "partition": 3 if len(self.live) > 1 else 0,
            "heal": 3 if self.partitioned else 0,
            "link": 4 if len(self.live) > 1 else 0,
            "inject": 10,
        }
        kind = rng.choices(list(kinds), weights=list(kinds.values()))[0]
        match kind:
            case "move":
                node = rng.choice(self.live)
                self.add(Move(node, self.moved(node)))
            case "start":
                label = self.next_label
                self.next_label += 1
                node = rng.choice(self.live)
                self.labels[label] = node
                role = "probe" if rng.random() < 0.8 else "decoy"
                faulty = rng.random() < 0.15
                self.add(Start(node, label, self.definition(), role, faulty))
            case "stop":
                label = rng.choice(sorted(self.labels))
                del self.labels[label]
                self.add(Stop(label))
            case "isend":
                count = rng.randint(1, 4) if rng.random() < 0.9 else rng.randint(50, 400)
                self.add(InitiatorSends(rng.choice(sorted(self.labels)), count))
            case "psend":
                count = rng.randint(1, 4) if rng.random() < 0.9 else rng.randint(50, 400)
                self.add(ParticipantSends(rng.choice(self.live), count))
            case "wait":
                self.add(Wait(round(rng.uniform(0.05, 2.0), 3)))
            case "crash" | "leave":
                node = rng.choice(self.live)
                self.live.remove(node)
                self.gone.append(node)
                self.drop_sessions_of(node)
                self.add(Crash(node) if kind == "crash" else Leave(node))
            case "restart":
                node = rng.choice(self.gone)
                self.gone.remove(node)
                self.live.append(node)
                self.placements[node] = self.placement()
                self.add(Restart(node, self.placements[node]))
            case "join":
                node = self.spare.pop(0)
                self.live.append(node)
                self.placements[node] = self.placement()
                self.add(Join(node, self.placements[node]))
            case "partition":
                nodes = sorted(self.live)
                rng.shuffle(nodes)
                cut = rng.randint(1, len(nodes) - 1)
                parts = [nodes[:cut], nodes[cut:]]
                if len(parts[1]) > 1 and rng.random() < 0.3:
                    parts = [parts[0], parts[1][:1], parts[1][1:]]
                self.partitioned = True
                self.add(Partition(tuple(tuple(sorted(part)) for part in parts)))
            case "heal":
                self.partitioned = False
                self.add(Heal())
            case "link":
                a, b = rng.sample(sorted(self.live), 2)
                loss = rng.choice([0.0, 0.05, 0.1, 0.2])
                duplicate = rng.choice([0.0, 0.05, 0.2])
                reorder = rng.choice([0.0, 0.1, 0.3])
                self.add(Link(a, b, loss, duplicate, reorder))
            case "inject":
                for _ in range(rng.randint(1, 5)):
                    kind_name, data = forge(rng, self.arena)
                    self.add(Inject(rng.choice(self.live), kind_name, data))
        if self.rest_rng is not None and self.live and self.rest_rng.random() < 0.2:
            self.add(Rest(self.rest_rng.choice(self.live), self.rest_rng.random() < 0.6))
        if rng.random() < 0.5:
            self.add(Wait(round(rng.uniform(0.01, 0.3), 3)))

    def calm(self) -> None:
        self.partitioned = False
        self.add(Heal())
        self.add(Settle())


def generate(seed: int, *, chaos_steps: tuple[int, int] = (40, 100), phases: int = 3) -> Scenario:
    """The scenario of ``seed``.

    Args:
        seed: any integer; the same seed gives the same scenario.
        chaos_steps: bounds of the number of steps of each chaos phase.
        phases: chaos phases, each followed by a calm checkpoint.
    """
    rng = random.Random(seed)
    count = rng.randint(3, 10)
    ids = [f"n{i}" for i in range(count + 3)]
    roles: dict[str, frozenset[str]] = {}
    for node in ids:
        pick = rng.random()
        if pick < 0.5:
            roles[node] = frozenset({"probe"})
        elif pick < 0.75:
            roles[node] = frozenset({"probe", "decoy"})
        elif pick < 0.9:
            roles[node] = frozenset()
        else:
            roles[node] = frozenset({"decoy"})
    arena = round(rng.uniform(8.0, 30.0), 3)
    # Half the seeds run with liveness beats and nodes at rest (docs/protocol.md §2),
    # drawn apart so that the rest of the scenario is the same either way.
    rest_rng = random.Random(f"rest:{seed}")
    resting = rest_rng.random() < 0.5
    builder = _Builder(
        rng,
        ids[count:],
        arena,
        rest_rng if resting else None,
        near_rng=random.Random(f"near:{seed}"),
    )
    builder.scoped = rng.random() < 0.4
    interest_radius = round(rng.uniform(14.0, 20.0), 3) if builder.scoped else None
    initial = []
    for node in ids[:count]:
        builder.placements[node] = builder.placement()
        builder.live.append(node)
        initial.append((node, builder.placements[node]))
    interval = round(rng.uniform(0.2, 0.5), 3)
    delay = round(rng.uniform(0.002, 0.02), 4)
    for _ in range(phases):
        for _ in range(rng.randint(*chaos_steps)):
            builder.chaos_step()
        builder.calm()
    builder.add(StopAll())
    builder.add(Settle(final=True))
    scenario = Scenario(
        seed=seed,
        initial=tuple(initial),
        roles=roles,
        delay=delay,
        jitter=round(rng.uniform(0.0, delay), 4),
        loss=rng.choice([0.0, 0.01, 0.05, 0.1, 0.2]),
        duplicate=rng.choice([0.0, 0.02, 0.1]),
        reorder=rng.choice([0.0, 0.05, 0.2]),
        cell_size=rng.choice([5.0, 10.0, 25.0]),
        # With beats every property is republished only every ten beats: else a node
        # at rest would publish every interval, and never rest.
        property_interval=10 * interval if resting else interval,
        failure_timeout=round(interval * rng.uniform(3.0, 5.0), 3),
        interest_radius=interest_radius,
        arena=arena,
        steps=tuple(builder.steps),
        beat_interval=interval if resting else None,
    )
    if not resting:
        return scenario
    # Rests as long as the timeout and longer: a peer that missed the announcement would
    # count the node failed before its next beat.
    rest = round(scenario.failure_timeout * rest_rng.uniform(0.7, 2.0), 3)
    # On half of them nothing is ever republished: the numbered publications and the
    # beats alone repair every loss (the fleet republishes once in 600 beats).
    republish = None if rest_rng.random() < 0.5 else scenario.property_interval
    return dataclasses.replace(scenario, rest_beat_interval=rest, property_interval=republish)
