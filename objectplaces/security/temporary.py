"""A throwaway fleet PKI in a private temporary folder: for the demo and tests.

```python
with TemporaryPki(fleet="demo") as pki:
    identity = pki.identity("agv-01", role="agv")   # issued on first ask
    ...                                             # the folder is gone after the block
```
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from types import TracebackType

from objectplaces.security.identity import Identity
from objectplaces.security.pki import init_ca, issue

__all__ = ["TemporaryPki"]


class TemporaryPki:
    """A fleet CA in a new 0700 temporary folder; ``remove()`` deletes it (again is fine).

    Args:
        fleet: the fleet's name.
    """

    def __init__(self, *, fleet: str = "default") -> None:
        self.directory = Path(tempfile.mkdtemp(prefix="objectplaces-pki-"))
        self.fleet = fleet
        init_ca(self.directory, fleet=fleet)

    def identity(
        self, node_id: str, *, role: str = "node", addresses: tuple[str, ...] = ()
    ) -> Identity:
        """The identity of ``node_id``, issuing its certificate the first time."""
        if not (self.directory / f"{node_id}.pem").exists():
            issue(self.directory, node_id, role=role, addresses=addresses)
        return Identity.from_pki(self.directory, node_id)

    def remove(self) -> None:
        """Delete the folder, keys and all."""
        shutil.rmtree(self.directory, ignore_errors=True)

    def __enter__(self) -> TemporaryPki:
        return self

    def __exit__(
        self,
        _type: type[BaseException] | None,
        _value: BaseException | None,
        _tb: TracebackType | None,
    ) -> None:
        self.remove()
