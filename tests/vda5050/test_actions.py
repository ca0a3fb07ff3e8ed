"""The action book on its own: statuses, blocking types, pause and cancel (no vehicle)."""

from __future__ import annotations

from agv_app.vda5050.actions import CATALOGUE, ActionBook, OrderAction
from agv_app.vda5050.reports import LOAD_HANDLING_FAILED, VdaError


class Timed:
    """Effects where every action runs for ``seconds[type]`` and ``boom`` fails."""

    def __init__(self, **seconds: float) -> None:
        self.seconds = seconds
        self.begun: list[tuple[str, float]] = []

    def begin(self, action: OrderAction, now: float) -> float | VdaError:
        self.begun.append((action.action_id, now))
        if action.action_type == "boom":
            return VdaError(LOAD_HANDLING_FAILED, "boom")
        return self.seconds.get(action.action_type, 0.0)

    def complete(self, action: OrderAction, now: float) -> str | VdaError:
        return f"{action.action_id} done"


def act(action_id: str, kind: str, blocking: str, seq: int = 0) -> OrderAction:
    return OrderAction(action_id, kind, blocking, f"N{seq}", seq)


def statuses(book: ActionBook) -> dict[str, str]:
    return {i: r.status for i, r in book.records.items()}


def test_actions_wait_for_their_node_then_run_for_their_time() -> None:
    book = ActionBook(Timed(pick=5.0))
    book.replace([act("a", "pick", "HARD", 2)])
    assert statuses(book) == {"a": "WAITING"}
    assert not book.blocks_driving, "a waiting action of a node ahead holds nothing"
    book.trigger(0, now=1.0)
    assert statuses(book) == {"a": "WAITING"}
    book.trigger(2, now=10.0)
    assert statuses(book) == {"a": "RUNNING"}
    assert book.blocks_driving
    book.advance(14.9)
    assert statuses(book) == {"a": "RUNNING"}
    book.advance(15.0)
    assert statuses(book) == {"a": "FINISHED"}
    assert book.records["a"].result == "a done"
    assert not book.blocks_driving
    assert book.idle


def test_none_and_soft_run_together_single_and_hard_alone() -> None:
    effects = Timed(x=2.0)
    book = ActionBook(effects)
    book.replace(
        [
            act("n", "x", "NONE"),
            act("s", "x", "SOFT"),
            act("h", "x", "HARD"),
            act("n2", "x", "NONE"),
            act("g", "x", "SINGLE"),
        ]
    )
    book.trigger(0, now=0.0)
    assert statuses(book) == {
        "n": "RUNNING",
        "s": "RUNNING",
        "h": "WAITING",
        "n2": "WAITING",
        "g": "WAITING",
    }
    assert book.blocks_driving
    book.advance(2.0)  # n and s end: h starts alone
    assert statuses(book)["h"] == "RUNNING"
    assert statuses(book)["n2"] == "WAITING"
    book.advance(4.0)  # h ends: n2 starts, g waits for it
    assert statuses(book)["n2"] == "RUNNING"
    assert statuses(book)["g"] == "WAITING"
    assert not book.blocks_driving, "SINGLE and NONE let the vehicle drive"
    book.advance(6.0)
    assert statuses(book)["g"] == "RUNNING"
    book.advance(8.0)
    assert book.idle
    assert [t for _, t in effects.begun] == [0.0, 0.0, 2.0, 4.0, 6.0]


def test_a_failing_action_reports_its_error_and_the_queue_goes_on() -> None:
    book = ActionBook(Timed(x=1.0))
    book.replace([act("b", "boom", "HARD"), act("x", "x", "HARD")])
    book.trigger(0, now=0.0)
    assert statuses(book) == {"b": "FAILED", "x": "RUNNING"}
    assert [e.error_type for e in book.take_errors()] == [LOAD_HANDLING_FAILED]
    assert book.take_errors() == []


def test_pause_keeps_the_time_left_and_starts_nothing_new() -> None:
    assert CATALOGUE["pick"].pause_allowed
    book = ActionBook(Timed(pick=5.0))
    book.replace([act("p", "pick", "HARD"), act("q", "pick", "HARD")])
    book.trigger(0, now=0.0)
    book.pause(2.0)
    assert statuses(book) == {"p": "PAUSED", "q": "WAITING"}
    book.advance(100.0)
    assert statuses(book) == {"p": "PAUSED", "q": "WAITING"}
    book.resume(100.0)
    book.advance(102.9)
    assert statuses(book)["p"] == "RUNNING"
    book.advance(103.0)
    assert statuses(book) == {"p": "FINISHED", "q": "RUNNING"}


def test_cancel_fails_what_waits_and_lets_a_load_handling_finish() -> None:
    assert not CATALOGUE["drop"].cancel_allowed
    book = ActionBook(Timed(drop=5.0))
    book.replace([act("d", "drop", "HARD", 0), act("c", "startCharging", "NONE", 4)])
    book.trigger(0, now=0.0)
    assert not book.cancel(), "the drop still runs"
    assert statuses(book) == {"d": "RUNNING", "c": "FAILED"}
    book.advance(5.0)
    assert statuses(book) == {"d": "FINISHED", "c": "FAILED"}
    assert book.idle


def test_an_update_drops_the_old_horizon_and_keeps_the_stitching_node() -> None:
    book = ActionBook(Timed())
    book.replace([act("a", "x", "NONE", 2), act("h", "x", "NONE", 6)])
    book.update(4, [act("a", "x", "NONE", 2), act("n", "x", "NONE", 8)])
    assert list(book.records) == ["a", "n"]
