"""A platform flapping between two relays: how often the swarm is not whole.

Run as root: ``.venv/bin/python scripts/relay_flap.py [--lease S] [--period S] [--seconds S]``.
Three relaying daemons (``--relay``) in network namespaces (the test suite's
:mod:`netns_lab`, ``tests/daemon``): 1 and 2 linked for good, 3 linked to both at the start
and then to one of them at a time, the two links swapped every ``--period`` seconds, as a
robot at the edge of two relays' ranges. Every 0.1 s it samples whether the three follow
master 1 and 1 holds both members; prints the share of samples in which they did not, and
platform 3's last master lines.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "daemon"))

from netns_lab import PREFIX, Radios

from actorswarm.daemon.launch import LocalSwarm

PORT = 7447


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lease", type=float, default=None, help="Zenoh's lease (default 3 s)")
    parser.add_argument("--period", type=float, default=1.5)
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    if os.geteuid() != 0:
        print("network namespaces need root", file=sys.stderr)
        return 2
    radios = Radios(f"{PREFIX}{os.getpid()}", "nftables", 0, 0)
    try:
        for a, b in ((1, 2), (1, 3), (2, 3), (0, 2)):
            radios.link(a, b)
        extra = [] if args.lease is None else ["--lease", str(args.lease)]
        with (
            tempfile.TemporaryDirectory() as tmp,
            LocalSwarm(
                Path(tmp),
                3,
                endpoints=[f"tcp/0.0.0.0:{PORT}"] * 3,
                links=radios.connects([1, 2, 3], PORT),
                gs_connect=[f"tcp/{radios.address(2, 0)}:{PORT}"],
                wrap=radios.wrap,
                relay=True,
                extra=extra,
            ) as swarm,
        ):
            swarm.start_all()
            swarm.wait("master 1", lambda: swarm.agreed_master([1, 2, 3]) == 1, timeout=40)
            began = time.monotonic()
            on_first = True
            samples = broken = 0
            while time.monotonic() - began < args.seconds:
                radios.set_link(1, 3, up=not on_first)
                radios.set_link(2, 3, up=on_first)
                on_first = not on_first
                for _ in range(max(1, round(args.period * 10))):
                    time.sleep(0.1)
                    samples += 1
                    masters = [swarm.status(p).get("master") for p in (1, 2, 3)]
                    if masters != [1, 1, 1] or len(swarm.status(1).get("members", ())) != 2:
                        broken += 1
            lines = [(round(e["t"] - began, 2), e.get("master")) for e in swarm.events(3, "master")]
            for p in (1, 2, 3):
                for e in swarm.events(p, "flapping"):
                    print(f"platform {p} at {e['t'] - began:.1f} s: {e['why']}")
            for p in (1, 2, 3):
                st = swarm.status(p)
                print(
                    f"platform {p}: master {st.get('master')}, members {st.get('members')}, "
                    f"traffic {st.get('traffic')}, rejected {st.get('rejected')}"
                )
        print(
            f"lease {args.lease or 3.0} s, links swapped every {args.period} s for "
            f"{args.seconds} s: not whole in {broken} of {samples} samples "
            f"({100 * broken / samples:.0f} %); platform 3's last master lines {lines[-6:]}"
        )
    finally:
        radios.teardown()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
