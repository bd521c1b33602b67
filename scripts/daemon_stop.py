#!/usr/bin/env python3
"""How long a daemon takes to stop (SIGTERM to exit) over lossy radio links.

Run as root, from the repository:
``.venv/bin/python scripts/daemon_stop.py [--platforms 10] [--loss 20] [--runs 10]
[--before SRC]``.

``--platforms`` daemons (secure, mesh) in network namespaces (the test suite's
:mod:`netns_lab`, ``tests/daemon``), every pair of them linked, every link end losing
``--loss`` % of what it sends (``tc netem``, or nftables where the kernel has no
``sch_netem``). Once they agree on a master, ``--runs`` times: one platform (2, 3, … in
turn; never platform 1, the master) is restarted, waited for until the whole swarm agrees
on its master again, then stopped with SIGTERM and timed until its process has exited.
With ``--before SRC`` each run also does so with the platform's daemon started from the
package under ``SRC/src`` (another checkout, e.g. ``git worktree add /tmp/before
HEAD~1``), before this one. Prints each stop, then the median, lowest and highest.
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "daemon"))

from netns_lab import full_mesh, lab_radios  # noqa: E402

from actorswarm.daemon.launch import LocalSwarm  # noqa: E402

PORT = 7447
#: How long a restarted platform is waited for until the whole swarm agrees on its master.
BACK_S = 120.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--loss", type=float, default=20.0, help="percent lost per link end")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--before", type=Path, help="a checkout to time the daemon of too")
    args = parser.parse_args()
    if not 3 <= args.platforms <= 20 or not 0 <= args.loss < 100 or args.runs < 1:
        parser.error("--platforms 3-20, --loss 0-99, --runs at least 1")
    if args.before is not None and not (args.before / "src" / "actorswarm").is_dir():
        parser.error(f"{args.before}: no src/actorswarm there")
    here = dict(os.environ)
    sources = {"this": here}
    if args.before is not None:
        before = here | {"PYTHONPATH": str((args.before / "src").resolve())}
        sources = {"before": before, "this": here}
    stops: dict[str, list[float]] = {label: [] for label in sources}
    everyone = list(range(1, args.platforms + 1))
    try:
        radios = lab_radios(args.loss)
    except RuntimeError as exc:
        print(f"cannot run: {exc}", file=sys.stderr)
        return 2
    try:
        with (
            tempfile.TemporaryDirectory() as tmp,
            full_mesh(radios, Path(tmp), args.platforms, PORT) as swarm,
        ):
            swarm.start_all()
            swarm.wait("a master", lambda: swarm.agreed_master(everyone) is not None, timeout=60)
            others = everyone[1:]
            for i in range(args.runs):
                for label, env in sources.items():
                    platform = others[i % len(others)]
                    try:
                        took = _stop_and_restart(swarm, platform, env, everyone)
                    except AssertionError:  # over such links the swarm may take longer
                        print(f"run {i + 1}, {label}: platform {platform} not back in the "
                              f"swarm within {BACK_S:g} s; no stop timed", flush=True)  # fmt: skip
                        continue
                    stops[label].append(took)
                    print(f"run {i + 1}, {label}: platform {platform} stopped in {took:.2f} s",
                          flush=True)  # fmt: skip
    finally:
        radios.teardown()
    print(f"{args.platforms} platforms, {radios.describe()}; SIGTERM to exit:")
    for label, values in stops.items():
        if not values:
            print(f"  {label}: no stop timed")
            continue
        print(f"  {label}: median {statistics.median(values):.2f} s "
              f"(min {min(values):.2f}, max {max(values):.2f}, {len(values)} stops)")  # fmt: skip
    return 0


def _stop_and_restart(
    swarm: LocalSwarm, platform: int, env: dict[str, str], everyone: list[int]
) -> float:
    """Restart ``platform``'s daemon with ``env``, wait until it is back in the swarm,
    and return how long its SIGTERM then takes to end the process, seconds."""
    proc = swarm.procs.pop(platform)
    proc.kill()
    proc.wait(timeout=15)
    swarm.env = env
    swarm.start(platform)
    swarm.wait(
        f"platform {platform} back",
        lambda: swarm.agreed_master(everyone) is not None,
        timeout=BACK_S,
    )
    time.sleep(2.0)  # its links to every peer up and carrying heartbeats
    proc = swarm.procs.pop(platform)
    began = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=60)
    took = time.monotonic() - began
    swarm.procs[platform] = proc  # restarted by the next run (killed: already exited)
    return took


if __name__ == "__main__":
    raise SystemExit(main())
