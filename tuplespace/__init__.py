"""A local Linda-style tuplespace for threads and asyncio tasks.

>>> space = TupleSpace()
>>> space.out(("locked", "agv-1", 3))
>>> space.rdp(("locked", ANY, int))
('locked', 'agv-1', 3)
>>> space.inp(("locked", "agv-2", ANY)) is None
True
"""

from __future__ import annotations

from ._match import ANY, Template, compile_template, match_fields
from ._space import KINDS, NotifyHandle, TupleSpace
from ._watch import Watch
from .errors import TupleSpaceError, WatchOverflow

__all__ = [
    "ANY",
    "KINDS",
    "NotifyHandle",
    "Template",
    "TupleSpace",
    "TupleSpaceError",
    "Watch",
    "WatchOverflow",
    "compile_template",
    "match_fields",
]
