"""Exceptions of the middleware.

Tree::

    ObjectPlacesError
    ├── LocalProtocolError       our caller misused the API (raised at the call)
    │   ├── NotPlainDataError    a value that is not plain data (also a TypeError)
    │   └── InvalidValueError    plain data, but not acceptable (also a ValueError)
    └── RemoteProtocolError      a peer sent something we cannot accept
        └── DecodeError          a frame that is malformed, oversized or of unknown type

Network input never raises out of the node: a ``RemoteProtocolError`` is caught where
the frame enters, counted and dropped.
"""

from __future__ import annotations

__all__ = [
    "DecodeError",
    "InvalidValueError",
    "LocalProtocolError",
    "NotPlainDataError",
    "ObjectPlacesError",
    "RemoteProtocolError",
]


class ObjectPlacesError(Exception):
    """Base of every exception raised by ObjectPlaces."""


class LocalProtocolError(ObjectPlacesError):
    """The caller broke the API contract (a bad argument, an unknown session)."""


class NotPlainDataError(LocalProtocolError, TypeError):
    """A property value or message holds something that is not plain data."""


class InvalidValueError(LocalProtocolError, ValueError):
    """Plain data that is still not acceptable (a position that is not two finite
    numbers, a value nested too deep or too large)."""


class RemoteProtocolError(ObjectPlacesError):
    """A peer sent input that violates the wire protocol."""


class DecodeError(RemoteProtocolError):
    """A frame could not be decoded: malformed, oversized, or of an unknown type."""
