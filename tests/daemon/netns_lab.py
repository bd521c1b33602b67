"""Network namespaces for the tests that put real daemons behind emulated radio links.

Every name made here starts with :data:`PREFIX`, this process's ID and ``-``, so parallel
runs never collide, and :func:`reap_leftovers` deletes those of runs whose process is gone
(a crash, a kill -9). Nothing is created in the machine's own namespace: each veth is made
inside a namespace of the test, its other end moved straight into another.

:class:`Radios` builds a swarm whose platforms reach only their neighbours: one namespace
per node (0 is the ground station), and one veth pair per radio link, on a subnet of its
own (``10.198.K.0/24`` for the K-th link). What each node sends on a link is lost with a
given probability and, where the kernel has ``sch_netem``, delayed (``tc netem`` on each
link end); without netem, nftables in each namespace drops that share of what it sends and
**no delay is emulated** (:func:`impairment` says which; tests say so in their output). No
IP routing is set up between links, so a packet crosses a link only where a daemon relays
it, as on a radio network where each robot hears only those in its range. Without netem, a
link's delay can still be had from :class:`Radios`' ``proxy_delay_ms``: each connection is
made through a TCP forwarder in the connecting node's namespace (``delay_proxy.py``) that
hands on every chunk that long after it read it, in each direction.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from actorswarm.daemon.launch import LocalSwarm

__all__ = [
    "PREFIX",
    "Radios",
    "full_mesh",
    "impairment",
    "lab_radios",
    "must",
    "netem",
    "reap_leftovers",
    "run",
]

#: Namespace names: this prefix, the ID of the process that made them, ``-`` and a role.
PREFIX = "asw"


def run(*cmd: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(cmd, input=stdin, capture_output=True, text=True, timeout=15, check=False)


def must(*cmd: str, stdin: str | None = None) -> str:
    """Run a set-up command: its output, or RuntimeError with the command and its error."""
    done = run(*cmd, stdin=stdin)
    if done.returncode != 0:
        raise RuntimeError(f"`{' '.join(cmd)}` failed ({done.returncode}): {done.stderr.strip()}")
    return done.stdout


def netem(loss_percent: float, delay_ms: float) -> tuple[str, ...]:
    """The ``tc qdisc add ... root`` arguments of a netem that loses and delays."""
    return ("netem", "loss", f"{loss_percent}%", "delay", f"{delay_ms}ms")


def reap_leftovers() -> None:
    """Delete the namespaces of runs whose process is gone: nobody else would."""
    for line in run("ip", "netns", "list").stdout.splitlines():
        name = line.split(" ", 1)[0]
        found = re.fullmatch(rf"{PREFIX}(\d+)-\w+", name)
        if found is None or int(found.group(1)) == os.getpid():
            continue
        try:
            os.kill(int(found.group(1)), 0)
        except ProcessLookupError:
            run("ip", "netns", "del", name)
        except PermissionError:
            pass  # alive: another user's run


def impairment(prefix: str) -> str:
    """``"netem"`` (loss and delay) or ``"nftables"`` (loss only): what this machine can do
    to a namespace's packets, tried on a throw-away namespace; pytest.skip naming what is
    missing when it can do neither, or cannot make namespaces and veth pairs."""
    if os.geteuid() != 0:
        pytest.skip("network namespaces need root (CAP_NET_ADMIN); CI runs this test as root")
    if shutil.which("ip") is None:
        pytest.skip("`ip` (iproute2) is not installed: run scripts/system-deps.sh as root")
    probe = f"{prefix}-probe"
    made = run("ip", "netns", "add", probe)
    if made.returncode != 0:
        pytest.skip(f"network namespaces are unavailable here: {made.stderr.strip()}")
    try:
        veth = run("ip", "-n", probe, "link", "add", "probe0", "type", "veth",
                   "peer", "name", "probe1")  # fmt: skip
        if veth.returncode != 0:
            pytest.skip(f"veth pairs are unavailable here: {veth.stderr.strip()}")
        qdisc = run("ip", "netns", "exec", probe, "tc", "qdisc", "add", "dev", "probe0",
                    "root", *netem(1, 1))  # fmt: skip
        if qdisc.returncode == 0:
            return "netem"
        if shutil.which("nft") is None:
            pytest.skip(
                f"no way to lose packets: tc netem failed ({qdisc.stderr.strip()}) and `nft` "
                "(nftables) is not installed: run scripts/system-deps.sh as root"
            )
        table = _nft_table(1)
        nft = run("ip", "netns", "exec", probe, "nft", "-f", "-", stdin=table)
        if nft.returncode != 0:
            pytest.skip(
                f"no way to lose packets: tc netem failed ({qdisc.stderr.strip()}) and "
                f"nftables failed ({nft.stderr.strip()})"
            )
        return "nftables"
    finally:
        run("ip", "netns", "del", probe)


def _nft_table(loss_percent: float) -> str:
    """A namespace's nftables table that counts what it sends on its links, then drops
    ``loss_percent`` of it (whole percents)."""
    return (
        "table inet radio {\n  chain out {\n"
        "    type filter hook output priority 0; policy accept;\n"
        '    oifname != "lo" counter\n'
        f'    oifname != "lo" numgen random mod 100 < {round(loss_percent)} counter drop\n'
        "  }\n}\n"
    )


@dataclass(slots=True)
class Radios:
    """Nodes (0: the ground station, then platforms) and the radio links between them.

    ``loss_percent`` and ``delay_ms``: what happens to every packet each end of a link sends
    (so a packet that crosses k links is delayed k times), by ``kind`` (:func:`impairment`;
    ``"nftables"`` emulates no delay). ``proxy_delay_ms``: a delay each way on every
    connection made through :meth:`via`, by a forwarder (the module's docstring), where
    netem cannot give one. Use :meth:`link` for every pair that hears each other, then
    :meth:`via` (or :meth:`address`) for where a neighbour connects; :meth:`teardown` at
    the end.
    """

    prefix: str
    kind: str
    loss_percent: float
    delay_ms: float
    made: list[str] = field(default_factory=list)
    #: (a, b) -> (a's address, b's address) on their link.
    addresses: dict[tuple[int, int], tuple[str, str]] = field(default_factory=dict)
    #: (a, b) -> (a's device, b's device) of their link.
    devices: dict[tuple[int, int], tuple[str, str]] = field(default_factory=dict)
    proxy_delay_ms: float = 0.0
    _ports: dict[int, int] = field(default_factory=dict)
    _proxies: list[subprocess.Popen[str]] = field(default_factory=list)

    def ns(self, node: int) -> str:
        return f"{self.prefix}-gs" if node == 0 else f"{self.prefix}-p{node}"

    def wrap(self, node: int) -> Sequence[str]:
        """The command prefix that runs a process in ``node``'s namespace."""
        return ["ip", "netns", "exec", self.ns(node)]

    def _node(self, node: int) -> None:
        name = self.ns(node)
        if name in self.made:
            return
        must("ip", "netns", "add", name)
        self.made.append(name)
        must("ip", "-n", name, "link", "set", "lo", "up")
        if self.kind == "nftables":
            must("ip", "netns", "exec", name, "nft", "-f", "-",
                 stdin=_nft_table(self.loss_percent))  # fmt: skip

    def link(self, a: int, b: int) -> None:
        """A radio link between nodes ``a`` and ``b`` (created with them if need be)."""
        self._node(a)
        self._node(b)
        k = len(self.addresses) + 1
        if k > 250:
            raise ValueError("at most 250 links")
        ends = []
        for node in (a, b):
            self._ports[node] = self._ports.get(node, 0) + 1
            ends.append(f"r{self._ports[node]}")
        must("ip", "-n", self.ns(a), "link", "add", ends[0], "type", "veth",
             "peer", "name", ends[1], "netns", self.ns(b))  # fmt: skip
        pair = (f"10.198.{k}.1", f"10.198.{k}.2")
        for node, dev, address in zip((a, b), ends, pair, strict=True):
            must("ip", "-n", self.ns(node), "addr", "add", f"{address}/24", "dev", dev)
            must("ip", "-n", self.ns(node), "link", "set", dev, "up")
            if self.kind == "netem":
                must("ip", "netns", "exec", self.ns(node), "tc", "qdisc", "add", "dev", dev,
                     "root", *netem(self.loss_percent, self.delay_ms))  # fmt: skip
        self.addresses[(a, b)] = pair
        self.devices[(a, b)] = (ends[0], ends[1])

    def set_link(self, a: int, b: int, *, up: bool) -> None:
        """Take the link between ``a`` and ``b`` down (both ends: out of range) or up."""
        pair = (a, b) if (a, b) in self.devices else (b, a)
        for node, dev in zip(pair, self.devices[pair], strict=True):
            must("ip", "-n", self.ns(node), "link", "set", dev, "up" if up else "down")

    def address(self, node: int, neighbour: int) -> str:
        """``node``'s address on its link with ``neighbour``."""
        if (node, neighbour) in self.addresses:
            return self.addresses[(node, neighbour)][0]
        return self.addresses[(neighbour, node)][1]

    def via(self, node: int, neighbour: int, port: int) -> str:
        """The endpoint ``node`` connects to, to reach ``neighbour`` listening on ``port``:
        its address on their link, or with ``proxy_delay_ms`` a forwarder started now in
        ``node``'s namespace that delays what crosses it."""
        target = self.address(neighbour, node)
        if not self.proxy_delay_ms:
            return f"tcp/{target}:{port}"
        script = str(Path(__file__).with_name("delay_proxy.py"))
        proc = subprocess.Popen(
            [
                *self.wrap(node),
                sys.executable,
                script,
                "0",
                target,
                str(port),
                str(self.proxy_delay_ms),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        self._proxies.append(proc)
        assert proc.stdout is not None
        ready = proc.stdout.readline().split()
        if len(ready) != 2 or ready[0] != "ready":
            raise RuntimeError(f"the delay proxy of {node} to {neighbour} did not start")
        return f"tcp/127.0.0.1:{ready[1]}"

    def connects(self, platforms: Sequence[int], port: int) -> dict[int, list[str]]:
        """Whom each platform connects to (``LocalSwarm(links=...)``): its neighbours with
        lower IDs, each listening on ``port``, through :meth:`via`."""
        return {
            p: [self.via(p, q, port) for q in self.neighbours(p) if 0 < q < p] for p in platforms
        }

    def neighbours(self, node: int) -> list[int]:
        return sorted({b if a == node else a for a, b in self.addresses if node in (a, b)})

    def describe(self) -> str:
        if self.proxy_delay_ms:
            return (
                f"{self.loss_percent} % lost per link end ({self.kind}) and "
                f"{self.proxy_delay_ms} ms each way per link by a TCP forwarder"
            )
        if self.kind == "netem":
            return f"{self.loss_percent} % lost and {self.delay_ms} ms delay per link end (netem)"
        return (
            f"{self.loss_percent} % lost per link end (nftables); NO delay emulated "
            f"({self.delay_ms} ms asked): this kernel has no sch_netem"
        )

    def drops(self) -> tuple[int, int]:
        """(packets lost, packets offered) on every link end so far."""
        lost = offered = 0
        for name in self.made:
            if self.kind == "netem":
                shown = run("ip", "netns", "exec", name, "tc", "-s", "qdisc", "show").stdout
                for found in re.finditer(r"qdisc netem .*?Sent \d+ bytes (\d+) pkt \(dropped (\d+)",
                                         shown, re.S):  # fmt: skip
                    offered += int(found.group(1)) + int(found.group(2))
                    lost += int(found.group(2))
                continue
            listed = run("ip", "netns", "exec", name, "nft", "-j", "list", "table", "inet",
                         "radio").stdout  # fmt: skip
            counts = [
                int(expr["counter"]["packets"])
                for item in json.loads(listed)["nftables"]
                for expr in item.get("rule", {}).get("expr", [])
                if "counter" in expr
            ]
            offered += counts[0]
            lost += counts[1]
        return lost, offered

    def teardown(self) -> None:
        """Stop the forwarders and delete every namespace made (their veths go with them)."""
        for proc in self._proxies:
            proc.kill()
            proc.wait()
        self._proxies.clear()
        for name in reversed(self.made):
            run("ip", "netns", "del", name)
        self.made.clear()


def lab_radios(loss_percent: float, delay_ms: float = 0) -> Radios:
    """Radios for a measurement script (``scripts/``), under a prefix of this process's
    own, after the namespaces earlier runs left are reaped. RuntimeError with the reason
    where this machine cannot make them (not root, no ``ip netns``, no way to lose
    packets)."""
    prefix = f"{PREFIX}{os.getpid()}"
    try:
        kind = impairment(prefix)
    except pytest.skip.Exception as exc:
        raise RuntimeError(str(exc)) from None
    reap_leftovers()
    return Radios(prefix, kind, loss_percent, delay_ms)


def full_mesh(
    radios: Radios, directory: Path, size: int, port: int, *, ground: bool = False
) -> LocalSwarm:
    """Platforms ``1..size`` over ``radios``, every pair linked (and with ``ground`` the
    ground station, node 0, linked to each): daemons listening on ``port`` of every
    address and connecting to each lower ID over their link; not started yet."""
    everyone = list(range(1, size + 1))
    for p in everyone:
        if ground:
            radios.link(0, p)
        for q in range(1, p):
            radios.link(q, p)
    return LocalSwarm(
        directory,
        size,
        endpoints=[f"tcp/0.0.0.0:{port}"] * size,
        links=radios.connects(everyone, port),
        gs_connect=[radios.via(0, p, port) for p in everyone] if ground else None,
        wrap=radios.wrap,
    )
