"""Hosts for the tests: network namespaces on veth pairs, made and removed by the test.

Two shapes:

``Network()``: each host a namespace joined to this (the test's) namespace by a veth
pair, the host end ``10.X.N.2/24``, ours ``10.X.N.1/24`` (its ``gateway``). Nothing
routes between hosts unless a test relays on purpose (a process of the test listening
on a gateway address), so every byte between two hosts crosses a relay it controls.

``Network(bridged=True)``: one switch namespace with a bridge, each host a namespace
on a veth pair to the bridge, all on ``10.X.0.0/24``: hosts reach each other directly,
as computers on one plant network. Faults: a host's link down and up
(``link_down``: Wi-Fi out of range), packet loss on what a host receives (``loss``:
nftables' ``numgen random``), a bandwidth cap both ways (``cap``: ``tc ... tbf``).

With ``attach=True`` the test's own namespace gets a leg on the bridge too
(``10.X.0.1``: ``address``), to reach the hosts' services directly.

``X`` is drawn from the process id, so two test workers never share addresses.
Everything is removed on exit, also when the test fails. Needs root and the programs
``ip``, ``tc`` and ``nft`` (``make test`` installs nftables); without them
``Network()`` fails with a message saying so, never a silent skip.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass
from types import TracebackType

__all__ = ["Host", "Network"]


@dataclass(frozen=True)
class Host:
    """One namespace: its name, its address, and where its link can be cut."""

    name: str
    address: str
    gateway: str
    """Our end's address (unbridged), "" on a bridge."""
    device: str
    """The far end of its veth pair: ours (unbridged), or the bridge's port."""
    inner: str
    """The host's own end of the pair, inside its namespace."""


def _run(argv: list[str], stdin: str | None = None) -> None:
    done = subprocess.run(argv, capture_output=True, text=True, timeout=30, input=stdin)
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)}: {done.stderr.strip()}")


def _ip(*args: str) -> None:
    _run(["ip", *args])


class Network:
    """Namespaced hosts of one test; a context manager that removes them all."""

    def __init__(self, *, bridged: bool = False, attach: bool = False) -> None:
        if os.geteuid() != 0:
            raise RuntimeError("network namespaces need root: run the suite as root (CI does)")
        for program in ("ip", "tc", "nft"):
            if shutil.which(program) is None:
                raise RuntimeError(f"{program} is missing: `make test` installs it")
        self._tag = f"op{os.getpid() % 100000}"
        self._octet = 100 + os.getpid() % 100
        self.bridged = bridged
        self.hosts: list[Host] = []
        self._switch = f"{self._tag}-sw"
        self.address = ""
        """Our own address on the bridge (``attach``), else ""."""
        self._leg = f"{self._tag}l"
        if bridged:
            _ip("netns", "add", self._switch)
            _ip("-n", self._switch, "link", "add", "br0", "type", "bridge")
            _ip("-n", self._switch, "link", "set", "br0", "up")
        if bridged and attach:  # a leg of our own on the bridge: we reach every host
            self.address = f"10.{self._octet}.0.1"
            _ip("link", "add", self._leg, "type", "veth", "peer", "name", f"{self._leg}p")
            _ip("link", "set", f"{self._leg}p", "netns", self._switch)
            _ip("-n", self._switch, "link", "set", f"{self._leg}p", "master", "br0")
            _ip("-n", self._switch, "link", "set", f"{self._leg}p", "up")
            _ip("addr", "add", f"{self.address}/24", "dev", self._leg)
            _ip("link", "set", self._leg, "up")

    def host(self, label: str) -> Host:
        """Make a new host (namespace and veth pair, both ends up)."""
        n = len(self.hosts) + 1
        name = f"{self._tag}-{label}"[:15]
        ours, theirs = f"{self._tag}h{n}"[:15], f"{self._tag}n{n}"[:15]
        if self.bridged:
            host = Host(name, f"10.{self._octet}.0.{n + 1}", "", ours, theirs)
        else:
            subnet = f"10.{self._octet}.{n}"
            host = Host(name, f"{subnet}.2", f"{subnet}.1", ours, theirs)
        _ip("netns", "add", name)
        self.hosts.append(host)
        _ip("link", "add", ours, "type", "veth", "peer", "name", theirs)
        _ip("link", "set", theirs, "netns", name)
        if self.bridged:
            _ip("link", "set", ours, "netns", self._switch)
            _ip("-n", self._switch, "link", "set", ours, "master", "br0")
            _ip("-n", self._switch, "link", "set", ours, "up")
            _ip("-n", name, "addr", "add", f"{host.address}/24", "dev", theirs)
        else:
            _ip("addr", "add", f"{host.gateway}/24", "dev", ours)
            _ip("link", "set", ours, "up")
            _ip("-n", name, "addr", "add", f"{host.address}/24", "dev", theirs)
        _ip("-n", name, "link", "set", theirs, "up")
        _ip("-n", name, "link", "set", "lo", "up")
        return host

    def command(self, host: Host, argv: list[str]) -> list[str]:
        """``argv`` run inside ``host``."""
        return ["ip", "netns", "exec", host.name, *argv]

    def _far(self, *args: str) -> list[str]:
        return ["ip", "-n", self._switch, *args] if self.bridged else ["ip", *args]

    def link_down(self, host: Host) -> None:
        """Cut ``host`` off (its link goes down, as a vehicle out of Wi-Fi range)."""
        _run(self._far("link", "set", host.device, "down"))

    def link_up(self, host: Host) -> None:
        """Bring ``host``'s link back."""
        _run(self._far("link", "set", host.device, "up"))

    def loss(self, host: Host, percent: int) -> None:
        """Drop ``percent`` % of the packets ``host`` receives, at random (0: none)."""
        _run(["ip", "netns", "exec", host.name, "nft", "flush", "ruleset"])
        if percent > 0:
            rules = (
                "table inet opfault {\n"
                "  chain input { type filter hook input priority 0; policy accept;\n"
                f'    iifname "{host.inner}" numgen random mod 100 < {int(percent)} drop\n'
                "  }\n"
                "}\n"
            )
            _run(["ip", "netns", "exec", host.name, "nft", "-f", "-"], stdin=rules)

    def cap(self, host: Host, kbit: int) -> None:
        """Cap ``host``'s link at ``kbit`` kbit/s each way (a token bucket, ``tbf``)."""
        shape = ["tbf", "rate", f"{kbit}kbit", "burst", "16kb", "latency", "500ms"]
        _run(["ip", "netns", "exec", host.name, "tc", "qdisc", "replace", "dev", host.inner,
              "root", *shape])  # fmt: skip
        far = ["tc", "qdisc", "replace", "dev", host.device, "root", *shape]
        _run(["ip", "netns", "exec", self._switch, *far] if self.bridged else far)

    def close(self) -> None:
        """Remove every host (its namespace takes its veth pair with it), and the switch."""
        for host in self.hosts:
            subprocess.run(["ip", "netns", "del", host.name], capture_output=True, timeout=30)
            if not self.bridged:
                subprocess.run(["ip", "link", "del", host.device], capture_output=True, timeout=30)
        self.hosts.clear()
        if self.bridged:
            subprocess.run(["ip", "netns", "del", self._switch], capture_output=True, timeout=30)
            subprocess.run(["ip", "link", "del", self._leg], capture_output=True, timeout=30)

    def __enter__(self) -> Network:
        return self

    def __exit__(
        self,
        _type: type[BaseException] | None,
        _value: BaseException | None,
        _tb: TracebackType | None,
    ) -> None:
        self.close()
