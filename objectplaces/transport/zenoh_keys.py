"""The key expressions of a fleet on Zenoh, and reading a sample's key back.

Every key of a fleet starts with ``objectplaces/<fleet>``. Below it:

- ``props/<cx>,<cy>/<node>``: a property update of ``node`` published in cell
  ``(cx, cy)``; ``props/<cx>,<cy>/<node>/left`` carries the same update to each other
  cell it concerns (a cell the node just left, or another cell of its footprint). A
  cell's subscribers declare ``props/<cx>,<cy>/**`` and hear both; full dissemination
  is the one wildcard ``props/*/*``, which hears each update once.
- ``all/<node>``: a broadcast of ``node`` (every node hears ``all/*``).
- ``to/<target>/<source>``: a frame for one node (session channels, snapshots); each
  node hears ``to/<itself>/*``.
- ``alive/<node>/<incarnation>/<tag>``: a node's liveliness token; the tag is what its
  application says every member shares (e.g. its layout's digest; ``-`` for none).
- ``who/<cx>,<cy>/<node>`` (or ``who/none/<node>`` before it has a cell): the node's
  queryable in each cell it publishes in, asked by a node that starts hearing that cell.

Node ids are escaped into one chunk (``%XX`` for any byte outside a safe set), so an id
can never add chunks or wildcards to a key. Sans-I/O: strings in, strings out.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Final

from objectplaces.core.errors import LocalProtocolError

__all__ = ["FleetKeys", "Inbound", "escape_id", "unescape_id"]

Cell = tuple[int, int]

_SAFE: Final = re.compile(r"[A-Za-z0-9_.:@+=-]")
_FLEET: Final = re.compile(r"[A-Za-z0-9_.-]{1,64}")
_NO_CELL: Final = "none"
_NO_TAG: Final = "-"
_PARSED_KEYS: Final = 4096
"""Sample keys whose reading a node remembers: a node hears few distinct keys (one per
sender and kind), and reading one costs microseconds on every sample otherwise."""


def escape_id(node: str) -> str:
    """``node`` as one key chunk: unsafe characters become ``%XX`` of their UTF-8 bytes."""
    if not node:
        raise LocalProtocolError("a node id must not be empty")
    out: list[str] = []
    for char in node:
        if _SAFE.fullmatch(char):
            out.append(char)
        else:
            out.extend(f"%{byte:02X}" for byte in char.encode())
    return "".join(out)


def unescape_id(chunk: str) -> str | None:
    """The node id escaped as ``chunk``; None if ``chunk`` is no escaped id."""
    raw = bytearray()
    i = 0
    try:
        while i < len(chunk):
            char = chunk[i]
            if char == "%":
                raw.append(int(chunk[i + 1 : i + 3], 16))
                i += 3
            elif _SAFE.fullmatch(char):
                raw.extend(char.encode())
                i += 1
            else:
                return None
        node = raw.decode()
    except (ValueError, IndexError):
        return None
    return node if node and escape_id(node) == chunk else None


def _cell_chunk(cell: Cell | None) -> str:
    return _NO_CELL if cell is None else f"{cell[0]},{cell[1]}"


def _parse_cell(chunk: str) -> Cell | None:
    """The cell a ``props`` key names (``cx,cy``, as ``_cell_chunk`` writes it)."""
    cx, sep, cy = chunk.partition(",")
    try:
        cell = (int(cx), int(cy))
    except ValueError:
        return None
    return cell if sep and _cell_chunk(cell) == chunk else None


@dataclass(frozen=True, slots=True)
class Inbound:
    """What a sample's key says: its kind (``props``, ``all``, ``to``), its sender, and
    for a property update the cell it was published in."""

    kind: str
    source: str
    cell: Cell | None = None


class FleetKeys:
    """The keys of one fleet, seen from one node.

    Args:
        fleet: the fleet's name (letters, digits, ``_.-``); fleets never hear each other.
        node: this node's id.
    """

    __slots__ = ("_me", "_parsed", "_tag", "node", "prefix", "tag")

    def __init__(self, fleet: str, node: str, tag: str = "") -> None:
        if not _FLEET.fullmatch(fleet):
            raise LocalProtocolError(f"a fleet name is 1-64 of [A-Za-z0-9_.-], got {fleet!r}")
        self.prefix = f"objectplaces/{fleet}"
        self.node = node
        self.tag = tag
        self._me = escape_id(node)
        self._tag = escape_id(tag) if tag else _NO_TAG
        self._parsed: dict[str, Inbound | None] = {}

    # ------------------------------------------------------------------ what we put

    def props(self, cell: Cell, *, left: bool = False) -> str:
        """Our property update published in ``cell`` (``left``: the cell we just left)."""
        key = f"{self.prefix}/props/{_cell_chunk(cell)}/{self._me}"
        return f"{key}/left" if left else key

    def broadcast(self) -> str:
        """Our broadcast."""
        return f"{self.prefix}/all/{self._me}"

    def to(self, target: str) -> str:
        """A frame from us to ``target``."""
        return f"{self.prefix}/to/{escape_id(target)}/{self._me}"

    def alive(self, incarnation: int) -> str:
        """Our liveliness token for this run."""
        return f"{self.prefix}/alive/{self._me}/{incarnation}/{self._tag}"

    def who(self, cell: Cell | None) -> str:
        """Our queryable while we publish in ``cell`` (None: in no cell)."""
        return f"{self.prefix}/who/{_cell_chunk(cell)}/{self._me}"

    # ------------------------------------------------------------------ what we hear

    def cell_subscription(self, cell: Cell) -> str:
        """Every update published in (or leaving) ``cell``."""
        return f"{self.prefix}/props/{_cell_chunk(cell)}/**"

    def row_subscription(self, row: int) -> str:
        """Every update published in (or leaving) a cell of row ``row`` (any column)."""
        return f"{self.prefix}/props/$*,{row}/**"

    def all_props(self) -> str:
        """Every property update, each once (full dissemination)."""
        return f"{self.prefix}/props/*/*"

    def broadcasts(self) -> str:
        """Every broadcast."""
        return f"{self.prefix}/all/*"

    def inbox(self) -> str:
        """Every frame for us."""
        return f"{self.prefix}/to/{self._me}/*"

    def alive_all(self) -> str:
        """Every node's liveliness token."""
        return f"{self.prefix}/alive/*/*/*"

    def who_in(self, cell: Cell | None) -> str:
        """The queryables of the nodes publishing in ``cell`` (None: in no cell)."""
        return f"{self.prefix}/who/{_cell_chunk(cell)}/*"

    def who_is(self, node: str) -> str:
        """The queryable of ``node``, wherever it publishes."""
        return f"{self.prefix}/who/*/{escape_id(node)}"

    def who_all(self) -> str:
        """Every node's queryable."""
        return f"{self.prefix}/who/*/*"

    # ------------------------------------------------------------------ reading keys

    def parse(self, key: str) -> Inbound | None:
        """Kind and sender of a data sample's key; None for a key that is none of ours.

        Remembers the readings of the last few thousand keys (safe from several threads:
        a reading is the same whoever made it, and a full memory starts afresh).
        """
        parsed = self._parsed
        try:
            return parsed[key]
        except KeyError:
            pass
        inbound = self._parse(key)
        if len(parsed) >= _PARSED_KEYS:
            parsed.clear()
        parsed[key] = inbound
        return inbound

    def _parse(self, key: str) -> Inbound | None:
        rest = _below(key, self.prefix)
        if rest is None:
            return None
        chunks = rest.split("/")
        kind = chunks[0]
        cell = None
        if kind == "props" and len(chunks) in (3, 4) and chunks[3:] in ([], ["left"]):
            sender = chunks[2]
            cell = _parse_cell(chunks[1])
            if cell is None:
                return None
        elif kind == "all" and len(chunks) == 2:
            sender = chunks[1]
        elif kind == "to" and len(chunks) == 3 and chunks[1] == self._me:
            sender = chunks[2]
        else:
            return None
        source = unescape_id(sender)
        return None if source is None else Inbound(kind, source, cell)

    def parse_alive(self, key: str) -> tuple[str, int, str] | None:
        """Node, incarnation and tag of a liveliness token's key; None if it is none of
        ours."""
        rest = _below(key, self.prefix)
        if rest is None:
            return None
        chunks = rest.split("/")
        if len(chunks) != 4 or chunks[0] != "alive" or not chunks[2].isdigit():
            return None
        node = unescape_id(chunks[1])
        tag = "" if chunks[3] == _NO_TAG else unescape_id(chunks[3])
        return None if node is None or tag is None else (node, int(chunks[2]), tag)


def _below(key: str, prefix: str) -> str | None:
    head = prefix + "/"
    return key[len(head) :] if key.startswith(head) else None
