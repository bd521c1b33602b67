"""Ten real daemons behind lossy links: one network namespace per daemon, a bridge between.

Each daemon and the ground station live in network namespaces of their own, with one
interface, ``eth0``, whose other end is a port of a bridge in a hub namespace. Addresses are
in 10.199.0.0/24, which exists only inside these namespaces: nothing is routed to or from
the machine's own network, and every interface is created inside its namespace.

The impairment is on what each daemon sends: 20 % of its packets are lost, and delayed
20 ms, with ``tc netem`` on its ``eth0`` where the kernel has ``sch_netem``. Where it does
not, nftables on the bridge drops 20 % of what comes in from each daemon's port, and **no
delay is emulated**; the test then says so in a warning and in its output. Either way each
packet between two daemons (data, acknowledgement, TCP handshake) crosses exactly one lossy
hop, its sender's, so each direction of every conversation loses 20 %. The ground station's
own link is clean; what the daemons send it is not.

Losing 20 % on *both* directions of every daemon's link instead (about 36 % of the packets
between two daemons, which cross two such links, and 59 % of the round trips) is more than
this swarm, over Zenoh and TCP, gets through: TCP's retransmission timeouts back off into
stalls of seconds, the membership never settles, and in trials no master was agreed within
a minute; neither a 2 s ``t_leave``, the phi detector nor a 10 s Zenoh lease brought the
script to its end. This test stays at what the issue asks for, 20 % per packet.

What the loss exercises: Zenoh carries the swarm over TCP, which retransmits a lost segment
itself, so the collective core sees no lost packet but links that stall until the
retransmission (200 ms and more; a retransmission lost again doubles the wait) and then
deliver in a burst. Heartbeats come late or Zenoh drops them (best effort, congestion
control *drop*), peers are declared gone and come back, masters change, a new ground
station session's links take seconds to open, and barrier requests, releases and
acknowledgements are late or lost. The branch-and-merge script must still complete: 2
platforms in B and 8 in C on one release, then all 10 back in A, no platform switching
twice for one event. A ``gs deploy`` or ``gs start`` that leaves a platform unconfirmed is
run again once, as an operator would, and said in the test's output; every other ``gs``
command must succeed the first time. The swarm's own behaviour is checked as it is.

The test needs root (``CAP_NET_ADMIN``), ``ip`` and either ``sch_netem`` or ``nft``
(``scripts/system-deps.sh`` installs ``iproute2`` and ``nftables``); without them it is
skipped with the reason. Namespace names carry this process's ID, so runs never collide;
they are deleted when the test ends however it ends, and those a crashed run left behind
(its process gone) are deleted by the next run.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import pytest
from netns_lab import PREFIX, impairment, must, netem, reap_leftovers, run

from actorswarm.daemon.launch import LocalSwarm

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "branch_merge.xml"
BRANCH, MERGE = "AtoBC_branch_event", "finish_event"
PLATFORMS = 10
SUBNET = "10.199.0"
PORT = 7447
LOSS_PERCENT = 20
DELAY_MS = 20


def _address(platform: int) -> str:
    """Platform ``platform``'s address; 0 is the ground station."""
    return f"{SUBNET}.{platform + 10}" if platform else f"{SUBNET}.2"


# --- what this machine can do -------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Impairment:
    """How the daemons' links are impaired: ``netem`` (loss and delay) or ``nftables``
    (loss only, ``delay_ms`` 0)."""

    kind: Literal["netem", "nftables"]
    loss_percent: int
    delay_ms: int

    def describe(self) -> str:
        if self.kind == "netem":
            return (
                f"tc netem on each daemon's eth0: {self.loss_percent} % of what it sends lost, "
                f"the rest delayed {self.delay_ms} ms"
            )
        return (
            f"nftables on the bridge: {self.loss_percent} % of what each daemon sends lost; "
            f"NO delay emulated ({DELAY_MS} ms asked): this kernel has no sch_netem"
        )


def _probe(prefix: str) -> Impairment:
    """What this machine offers (:func:`netns_lab.impairment`); pytest.skip naming what is
    missing when the test cannot run here."""
    if impairment(prefix) == "netem":
        return Impairment("netem", LOSS_PERCENT, DELAY_MS)
    return Impairment("nftables", LOSS_PERCENT, 0)


# --- the topology ---------------------------------------------------------------------------


@dataclass(slots=True)
class Topology:
    """A hub namespace with a bridge, one namespace per platform (0: the ground station)."""

    prefix: str
    size: int
    impairment: Impairment
    made: list[str] = field(default_factory=list)

    @property
    def hub(self) -> str:
        return f"{self.prefix}-hub"

    def ns(self, platform: int) -> str:
        return f"{self.prefix}-gs" if platform == 0 else f"{self.prefix}-p{platform}"

    @staticmethod
    def port(platform: int) -> str:
        """The bridge's port toward ``platform`` (a name in the hub namespace only)."""
        return "gs" if platform == 0 else f"p{platform}"

    def wrap(self, platform: int) -> Sequence[str]:
        """The command prefix that runs a process in ``platform``'s namespace."""
        return ["ip", "netns", "exec", self.ns(platform)]

    def build(self) -> None:
        """Create every namespace, link and address, then impair the daemons' links."""
        self._netns(self.hub)
        must("ip", "-n", self.hub, "link", "add", "br0", "type", "bridge")
        must("ip", "-n", self.hub, "link", "set", "br0", "up")
        for platform in range(self.size + 1):
            ns, port = self.ns(platform), self.port(platform)
            self._netns(ns)
            # Made in the hub with its peer moved straight into the platform's namespace:
            # no interface of the test ever exists in the machine's own namespace.
            must("ip", "-n", self.hub, "link", "add", port, "type", "veth",
                  "peer", "name", "eth0", "netns", ns)  # fmt: skip
            must("ip", "-n", self.hub, "link", "set", port, "master", "br0", "up")
            must("ip", "-n", ns, "addr", "add", f"{_address(platform)}/24", "dev", "eth0")
            must("ip", "-n", ns, "link", "set", "eth0", "up")
        if self.impairment.kind == "netem":
            for platform in range(1, self.size + 1):
                must("ip", "netns", "exec", self.ns(platform), "tc", "qdisc", "add", "dev",
                      "eth0", "root", *netem(self.impairment.loss_percent,
                                              self.impairment.delay_ms))  # fmt: skip
        else:
            must("ip", "netns", "exec", self.hub, "nft", "-f", "-", stdin=self._nft_table())

    def _nft_table(self) -> str:
        # The bridge's forward hook sees every frame from one port to another. Per daemon
        # port: a rule that only counts what it sends, then one that drops a share of it.
        loss = self.impairment.loss_percent
        rules: list[str] = []
        for platform in range(1, self.size + 1):
            port = self.port(platform)
            rules += [
                f'iifname "{port}" counter',
                f'iifname "{port}" numgen random mod 100 < {loss} counter drop',
            ]
        body = "\n    ".join(rules)
        return (
            "table bridge radio {\n  chain links {\n"
            "    type filter hook forward priority 0; policy accept;\n"
            f"    {body}\n  }}\n}}\n"
        )

    def dropped(self) -> tuple[int, int] | None:
        """(packets dropped, packets the daemons sent) as the impairment counted them so far;
        None when the counters cannot be read."""
        try:
            if self.impairment.kind == "nftables":
                listed = run("ip", "netns", "exec", self.hub, "nft", "-j", "list", "table",
                              "bridge", "radio").stdout  # fmt: skip
                counts = [
                    int(expr["counter"]["packets"])
                    for item in json.loads(listed)["nftables"]
                    for expr in item.get("rule", {}).get("expr", [])
                    if "counter" in expr
                ]
                # (offered, dropped) pairs, in the order the rules were written.
                return sum(counts[1::2]), sum(counts[0::2])
            lost = sent = 0
            for platform in range(1, self.size + 1):
                shown = run("ip", "netns", "exec", self.ns(platform), "tc", "-s", "-j",
                             "qdisc", "show", "dev", "eth0").stdout  # fmt: skip
                for qdisc in json.loads(shown):
                    if qdisc.get("kind") == "netem":
                        # netem counts a packet it loses as a drop, never as sent.
                        lost += int(qdisc["drops"])
                        sent += int(qdisc["packets"]) + int(qdisc["drops"])
            return lost, sent
        except (ValueError, KeyError, TypeError):
            return None

    def _netns(self, name: str) -> None:
        must("ip", "netns", "add", name)
        self.made.append(name)
        must("ip", "-n", name, "link", "set", "lo", "up")

    def teardown(self) -> None:
        """Delete every namespace made (their veths and the bridge go with them)."""
        for name in reversed(self.made):
            run("ip", "netns", "del", name)
        self.made.clear()


@pytest.fixture
def topology() -> Iterator[Topology]:
    prefix = f"{PREFIX}{os.getpid()}"
    impairment = _probe(prefix)
    reap_leftovers()
    topo = Topology(prefix, PLATFORMS, impairment)
    try:
        topo.build()
        yield topo
    finally:
        topo.teardown()


# --- the test -----------------------------------------------------------------------------


def _actors(swarm: LocalSwarm) -> dict[int, list[str]]:
    return {p: list(swarm.status(p).get("actors") or []) for p in range(1, PLATFORMS + 1)}


def _transitions(swarm: LocalSwarm, platform: int) -> list[tuple[str, str, str, str]]:
    rows: list[dict[str, Any]] = swarm.status(platform).get("transitions") or []
    return [(r["from"], r["to"], r["event"], r["cause"]) for r in rows]


def _gs(swarm: LocalSwarm, *args: str) -> str:
    """Run ``gs ARGS`` in the ground station's namespace; its output (the test fails with
    what it said when it fails)."""
    return _said(swarm, args, swarm.gs(*args, timeout=90))


def _said(swarm: LocalSwarm, args: Sequence[str], done: subprocess.CompletedProcess[str]) -> str:
    """What ``gs ARGS`` printed, or the test fails with it and what each platform refused
    (a refusal and a dead link read alike from the ground station)."""
    if done.returncode != 0:
        refused = {p: swarm.status(p).get("rejected") for p in swarm.platforms}
        raise AssertionError(
            f"gs {' '.join(args)}: {done.stdout}{done.stderr}\npackets refused: {refused}"
        )
    return done.stdout


def _gs_unconfirmed_again(swarm: LocalSwarm, mark: Callable[[str], None], *args: str) -> str:
    """``gs ARGS`` (deploy or start), run again once when a platform did not confirm the
    script, as an operator would: then nothing was started, and the platforms that have
    the script confirm at once. Said through ``mark``, with what each platform refused.

    Why: a new ground-station session's first message sometimes reaches one platform 10-14
    s after the others over these links (in about one run in four beside two CPU hogs,
    before and after the ``gs`` commands stopped waiting for Zenoh's close); in one CI run
    of many, not within 30 s. The cause is not known: the session's Zenoh links to all ten
    opened within 0.5-2.6 s in 15 trials here, and the operator's events of the same runs
    reached all ten within a second."""
    first = swarm.gs(*args, timeout=90)
    if first.returncode == 0 or "not confirmed by" not in first.stderr:
        return _said(swarm, args, first)
    refused = {p: swarm.status(p).get("rejected") for p in swarm.platforms}
    mark(f"{args[0]} again ({' '.join(first.stderr.split())[:300]}; refused {refused})")
    return _gs(swarm, *args)


@pytest.mark.parametrize("broadcast", ["mesh", "multicast"])
def test_branch_and_merge_complete_over_lossy_links(
    topology: Topology, tmp_path: Path, broadcast: str
) -> None:
    """Ten daemons, each in its namespace, each losing 20 % of what it sends (and delaying
    it 20 ms where the kernel can): deploy, start, branch into 2 B + 8 C on one release,
    merge back into 10 A, each platform switching exactly once per event. Over the TCP
    mesh, and with every daemon and the ground station on a multicast group through their
    ``eth0`` (``--broadcast multicast``: a datagram lost at its sender's port is lost for
    every member, and nothing below the core retransmits it)."""
    impairment = topology.impairment
    if impairment.kind != "netem":
        warnings.warn(f"links impaired by {impairment.describe()}", stacklevel=1)
    everyone = tuple(range(1, PLATFORMS + 1))
    ids = f"1-{PLATFORMS}"
    state = ["--state", str(tmp_path / "gs.json")]
    if broadcast == "mesh":
        endpoints = [f"tcp/{_address(p)}:{PORT}" for p in everyone]
        where: dict[str, Any] = {"endpoints": endpoints}
    else:
        where = {"group": f"224.0.0.225:{PORT + 1}", "interface": "eth0"}
    with LocalSwarm(tmp_path / "swarm", PLATFORMS, wrap=topology.wrap, **where) as swarm:
        started = time.monotonic()
        steps: list[str] = []  # when each step was done, for the output

        def mark(step: str) -> None:
            steps.append(f"{step} {time.monotonic() - started:.1f}")

        swarm.start_all()
        swarm.wait(
            "ten daemons that agree on a master",
            lambda: swarm.agreed_master(everyone) is not None,
            timeout=45,
            detail=lambda: f"masters {[swarm.status(p).get('master') for p in everyone]}",
        )
        mark("master agreed")
        deploy = ("deploy", str(SCRIPT), "--expect", ids, "--timeout", "30", *state)
        deployed = _gs_unconfirmed_again(swarm, mark, *deploy)
        assert f"confirmed by {PLATFORMS} of {PLATFORMS}" in deployed
        mark("deployed")
        launched = _gs_unconfirmed_again(swarm, mark, "start", "--timeout", "30", *state)
        assert f"started on {PLATFORMS} of {PLATFORMS}" in launched
        swarm.wait(
            "every platform in A",
            lambda: all(a == ["A"] for a in _actors(swarm).values()),
            detail=lambda: f"actors {_actors(swarm)}",
        )
        mark("started")

        fired = _gs(swarm, "event", BRANCH, "--platforms", ids, "--timeout", "20")
        assert fired.count(f"event {BRANCH} delivered") == PLATFORMS, fired

        def branched() -> bool:
            actors = list(_actors(swarm).values())
            return actors.count(["B"]) == 2 and actors.count(["C"]) == 8

        # Within the script's own 60 s (timeoutBranch), after which a platform would switch
        # alone: a switch on a timeout fails the transition check below, by its cause.
        swarm.wait("2 platforms in B and 8 in C", branched, timeout=40,
                   detail=lambda: f"actors {_actors(swarm)}")  # fmt: skip
        mark("branched")

        fired = _gs(swarm, "event", MERGE, "--platforms", ids, "--timeout", "20")
        assert fired.count(f"event {MERGE} delivered") == PLATFORMS, fired
        swarm.wait("all ten back in A", lambda: all(a == ["A"] for a in _actors(swarm).values()),
                   timeout=40, detail=lambda: f"actors {_actors(swarm)}")  # fmt: skip
        mark("merged")
        # A release that reaches a platform again late, after a stalled link let go, must
        # not switch it a second time: give stragglers time to arrive and the daemons time
        # to write their status once more before counting.
        time.sleep(2.5)
        for p in everyone:
            got = _transitions(swarm, p)
            to = got[1][1] if len(got) > 1 else "?"
            expected = [("", "A", "", "start"), ("A", to, BRANCH, "barrier"),
                        (to, "A", MERGE, "barrier")]  # fmt: skip
            assert to in ("B", "C") and got == expected, (
                f"platform {p}: transitions {got}; expected start, branch and merge once "
                "each, the last two on a barrier release"
            )
        dropped = topology.dropped()
    assert dropped is not None, "the impairment's counters could not be read"
    lost, sent = dropped
    # The impairment really was in force: about the asked share of what the daemons sent
    # was lost (thousands of packets, so a fair coin lands well inside these bounds).
    assert sent > 1000 and 0.5 * LOSS_PERCENT < 100 * lost / sent < 1.5 * LOSS_PERCENT, dropped
    print(
        f"\nbranch and merge ({broadcast}) over {impairment.describe()}; {lost} of {sent} "
        f"packets the daemons sent were lost ({100 * lost / sent:.1f} %); seconds from the "
        f"daemons' start: {', '.join(steps)}"
    )
