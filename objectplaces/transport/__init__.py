"""Transports: the in-memory simulated network and the WebSocket mesh.

They import only ``objectplaces.core`` and each other, never a runtime: what they need
from whoever drives a node is the ``NodeDriver`` (and, for the in-memory network, the
``Scheduler``) in ``base``. Modules:

- ``base``: those Protocols, ``Endpoint`` and the cell key scheme;
- ``routing``: ``CellRouter``, who hears a publication (both transports);
- ``memory``: the in-memory network of the simulation;
- ``mesh_frames``: the mesh's own frames (handshake, gossip, subscriptions, batches);
- ``handshake``, ``directory``, ``policing``: the mesh's sans-I/O parts;
- ``options``: the mesh's limits and timings;
- ``link``, ``connector``, ``websocket``: the mesh's asyncio shell.
"""

__all__: list[str] = []
