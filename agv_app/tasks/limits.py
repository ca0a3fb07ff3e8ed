"""How many tasks a task desk holds and lets onto the floor: the bound on open tasks
(:data:`BACKLOG_LIMIT`, :class:`BacklogFull`) and the check and parsing of a desk's
``max_open`` (:class:`~agv_app.tasks.desk.TaskDesk`).
"""

from __future__ import annotations

from mypy_extensions import mypyc_attr

from agv_app.tasks.admission import CROWDED

__all__ = ["BACKLOG_LIMIT", "BacklogFull", "check_max_open", "parse_max_open"]


BACKLOG_LIMIT = 10_000
"""Open tasks a desk holds at most: waiting at the desk, at their stations or on an AGV.
Orders from outside (the dashboard's API, a master control) come as fast as a client
sends them, and each open task keeps a record and, at its station, an auction: the bound
keeps a burst from growing memory and work without end. A fleet at its load never comes
near it (tasks are done as fast as they come)."""


# Not a native class when compiled (objectplaces.compiled): mypyc builds no native
# subclass of a built-in exception.
@mypyc_attr(native_class=False)
class BacklogFull(RuntimeError):
    """The desk holds its limit of open tasks: a new one is refused (and counted) until
    some are done or cancelled."""


def check_max_open(max_open: object) -> None:
    """Check a desk's ``max_open``: None, ``"auto"`` or a whole number >= 1.

    Raises:
        ValueError: it is none of these.
    """
    if max_open is None or max_open == "auto":
        return
    if isinstance(max_open, bool) or not isinstance(max_open, int) or max_open < 1:
        raise ValueError(f"max_open must be a whole number >= 1, 'auto' or None, got {max_open!r}")


def parse_max_open(text: str) -> int | str | None:
    """A command line's limit on open tasks: ``"auto"``, ``"crowded"``
    (:data:`~agv_app.tasks.admission.CROWDED`), ``"none"`` (no limit: None) or a whole
    number (checked to be at least 1 with :func:`check_max_open`).

    Raises:
        ValueError: none of them.
    """
    if text in ("auto", CROWDED):
        return text
    if text == "none":
        return None
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"a whole number, 'auto', 'crowded' or 'none', got {text!r}") from None
