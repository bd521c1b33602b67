"""A master that goes silent against one that is killed: how long the others take to agree
on a new master, with plain (not relaying) daemons.

Run as root: ``.venv/bin/python scripts/silent_master.py [--runs N]``. Three daemons in
network namespaces (the test suite's :mod:`netns_lab`, ``tests/daemon``), every pair
linked, each link on its own subnet. Once all follow master 1, either platform 1 is
SIGKILLed (its peers' connections are reset) or every packet it sends or receives on its
links is dropped by nftables (it flew out of range: nothing tells the others, no
connection closes). Prints, per run, the seconds until 2 and 3 both follow master 2.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "daemon"))

from netns_lab import PREFIX, Radios, must

from actorswarm.daemon.launch import LocalSwarm

PORT = 7447


def silence(radios: Radios, node: int) -> None:
    """Drop everything ``node`` sends or receives on its links, silently."""
    nft = ["ip", "netns", "exec", radios.ns(node), "nft"]
    must(*nft, "insert", "rule", "inet", "radio", "out", "oifname", "!=", "lo", "drop")
    must(*nft, "add", "chain", "inet", "radio", "in",
         "{ type filter hook input priority 0 ; policy accept ; }")  # fmt: skip
    must(*nft, "add", "rule", "inet", "radio", "in", "iifname", "!=", "lo", "drop")


def once(how: str) -> float | None:
    """Seconds from the kill or the silence until 2 and 3 follow master 2 (None: 30 s
    passed)."""
    radios = Radios(f"{PREFIX}{os.getpid()}", "nftables", 0, 0)
    try:
        for a, b in ((1, 2), (1, 3), (2, 3)):
            radios.link(a, b)
        with (
            tempfile.TemporaryDirectory() as tmp,
            LocalSwarm(
                Path(tmp),
                3,
                endpoints=[f"tcp/0.0.0.0:{PORT}"] * 3,
                links=radios.connects([1, 2, 3], PORT),
                wrap=radios.wrap,
            ) as swarm,
        ):
            swarm.start_all()
            swarm.wait("master 1", lambda: swarm.agreed_master([1, 2, 3]) == 1, timeout=40)
            time.sleep(3.0)
            began = time.monotonic()
            if how == "kill":
                swarm.kill(1)
            else:
                silence(radios, 1)
            while time.monotonic() - began < 30.0:
                if [swarm.status(p).get("master") for p in (2, 3)] == [2, 2]:
                    return time.monotonic() - began
                time.sleep(0.02)
            return None
    finally:
        radios.teardown()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    if os.geteuid() != 0:
        print("network namespaces need root", file=sys.stderr)
        return 2
    for how in ("kill", "silent"):
        times = [once(how) for _ in range(args.runs)]
        done = [t for t in times if t is not None]
        shown = ", ".join("never" if t is None else f"{t:.2f}" for t in times)
        median = f"median {statistics.median(done):.2f} s" if done else "never"
        print(f"master {'killed' if how == 'kill' else 'silent'}: {shown} s ({median})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
