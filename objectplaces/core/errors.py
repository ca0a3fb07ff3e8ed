"""Exceptions of the middleware.

Tree::

    ObjectPlacesError
    ├── LocalProtocolError       our caller misused the API (raised at the call)
    └── RemoteProtocolError      a peer sent something we cannot accept
        └── DecodeError          a frame that is malformed, oversized or of unknown type

Network input never raises out of the node: a ``RemoteProtocolError`` is caught where
the frame enters, counted and dropped.
"""

from __future__ import annotations

__all__ = ["DecodeError", "LocalProtocolError", "ObjectPlacesError", "RemoteProtocolError"]


class ObjectPlacesError(Exception):
    """Base of every exception raised by ObjectPlaces."""


class LocalProtocolError(ObjectPlacesError):
    """The caller broke the API contract (a bad argument, an unknown session)."""


class RemoteProtocolError(ObjectPlacesError):
    """A peer sent input that violates the wire protocol."""


class DecodeError(RemoteProtocolError):
    """A frame could not be decoded: malformed, oversized, or of an unknown type."""
