"""Exceptions of the tuplespace.

Misuse is reported with the built-in exceptions a Python programmer expects:
``TypeError`` (a non-tuple, a bad template), ``ValueError`` (a negative lease or
timeout), ``TimeoutError`` (a blocking read or take that ran out of time). The
package's own conditions derive from one base::

    TupleSpaceError
     └── WatchOverflow    a watcher fell too far behind and missed tuples
"""

from __future__ import annotations

__all__ = ["TupleSpaceError", "WatchOverflow"]


class TupleSpaceError(Exception):
    """Base of every exception specific to the tuplespace."""


class WatchOverflow(TupleSpaceError):
    """A ``watch`` iterator buffered more tuples than allowed; some were dropped.

    Raised by the iterator once the buffered tuples before the overflow were consumed.
    """
