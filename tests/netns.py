"""Hosts for the tests: network namespaces on veth pairs, made and removed by the test.

```python
with Network() as net:
    a = net.host("a")                 # namespace with 10.X.1.2, its gateway 10.X.1.1
    b = net.host("b")                 # 10.X.2.2, gateway 10.X.2.1
    net.run(a, ["python", ...])       # a command inside host a
    net.link_down(a) ... net.link_up(a)
```

Each host is a namespace joined to this (the test's) namespace by a veth pair: the host
end holds ``10.X.N.2/24``, our end ``10.X.N.1/24``. Nothing routes between hosts unless
a test relays on purpose (a process of the test listening on a gateway address), so
every byte between two hosts crosses a relay the test controls. ``X`` is drawn from the
process id, so two test workers never share addresses. Everything is removed on exit,
also when the test fails. Needs root (CI runs as root); without it ``Network()`` fails
with a message saying so, never a silent skip.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass
from types import TracebackType

__all__ = ["Host", "Network"]


@dataclass(frozen=True)
class Host:
    """One namespace: its name, its address, and the address of our end of its link."""

    name: str
    address: str
    gateway: str
    device: str
    """Our end of the veth pair (down on it cuts the host off)."""


def _ip(*args: str) -> None:
    done = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)
    if done.returncode != 0:
        raise RuntimeError(f"ip {' '.join(args)}: {done.stderr.strip()}")


class Network:
    """Namespaced hosts of one test; a context manager that removes them all."""

    def __init__(self) -> None:
        if os.geteuid() != 0:
            raise RuntimeError("network namespaces need root: run the suite as root (CI does)")
        self._tag = f"op{os.getpid() % 100000}"
        self._octet = 100 + os.getpid() % 100
        self.hosts: list[Host] = []

    def host(self, label: str) -> Host:
        """Make a new host (namespace and veth pair, both ends up)."""
        n = len(self.hosts) + 1
        name = f"{self._tag}-{label}"[:15]
        ours, theirs = f"{self._tag}h{n}"[:15], f"{self._tag}n{n}"[:15]
        subnet = f"10.{self._octet}.{n}"
        host = Host(name, f"{subnet}.2", f"{subnet}.1", ours)
        _ip("netns", "add", name)
        self.hosts.append(host)
        _ip("link", "add", ours, "type", "veth", "peer", "name", theirs)
        _ip("link", "set", theirs, "netns", name)
        _ip("addr", "add", f"{host.gateway}/24", "dev", ours)
        _ip("link", "set", ours, "up")
        _ip("-n", name, "addr", "add", f"{host.address}/24", "dev", theirs)
        _ip("-n", name, "link", "set", theirs, "up")
        _ip("-n", name, "link", "set", "lo", "up")
        return host

    def command(self, host: Host, argv: list[str]) -> list[str]:
        """``argv`` run inside ``host``."""
        return ["ip", "netns", "exec", host.name, *argv]

    def link_down(self, host: Host) -> None:
        """Cut ``host`` off (its link goes down, as a vehicle out of Wi-Fi range)."""
        _ip("link", "set", host.device, "down")

    def link_up(self, host: Host) -> None:
        """Bring ``host``'s link back."""
        _ip("link", "set", host.device, "up")

    def close(self) -> None:
        """Remove every host (its namespace takes its veth pair with it)."""
        for host in self.hosts:
            subprocess.run(["ip", "netns", "del", host.name], capture_output=True, timeout=30)
            subprocess.run(["ip", "link", "del", host.device], capture_output=True, timeout=30)
        self.hosts.clear()

    def __enter__(self) -> Network:
        return self

    def __exit__(
        self,
        _type: type[BaseException] | None,
        _value: BaseException | None,
        _tb: TracebackType | None,
    ) -> None:
        self.close()
