#!/usr/bin/env python3
"""Where the daemons running on this machine spend their CPU, and how often their loops
wake (docs/benchmarks/README.md, "Heartbeats that stay on the master's wakes"). Run it
while a swarm of daemons runs (``actorswarm bench table1 --mode real``, ``actorswarm
bench daemons``, ``actorswarm launch``...), with the project's interpreter:

    .venv/bin/python scripts/daemon_threads.py [--window 40]

Every process whose command line holds ``daemon`` and ``--platform N`` is a daemon. Over
``--window`` seconds, from ``/proc/PID/task/*/stat`` and ``status``: each daemon's CPU as
a percentage of one core, split between its main thread (Python: the asyncio loop, the
core, the engine, the plugins) and its other threads (Zenoh's), and the voluntary context
switches of its main thread a second (*wakes/s*: each time the loop slept, waited for the
GIL or for a disk write). Prints the median over the members (every daemon but platform
1, the master of a swarm that formed undisturbed) and platform 1's figures, as one line
and, with ``--json``, every daemon's.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

from actorswarm.bench.daemons import read_cpu_seconds, read_sleeps


def _platform(pid: str) -> int | None:
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
    except OSError:
        return None
    if b"daemon" not in argv or b"--platform" not in argv:
        return None
    try:
        return int(argv[argv.index(b"--platform") + 1])
    except (IndexError, ValueError):
        return None


def _snapshot() -> dict[int, tuple[float, float, int]]:
    """platform -> (main thread's CPU seconds, the process's CPU seconds, main thread's
    voluntary context switches)."""
    out: dict[int, tuple[float, float, int]] = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        platform = _platform(pid)
        if platform is None:
            continue
        try:
            main = read_cpu_seconds(int(pid), thread=int(pid))
            out[platform] = (main, read_cpu_seconds(int(pid)), read_sleeps(int(pid)))
        except (OSError, ValueError):  # the daemon exited meanwhile
            continue
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--window", type=float, default=40.0, help="seconds (default 40)")
    parser.add_argument("--json", action="store_true", help="every daemon's figures too")
    args = parser.parse_args()
    before = _snapshot()
    time.sleep(args.window)
    after = _snapshot()
    rows: dict[int, dict[str, float]] = {}
    for platform, (main0, whole0, wakes0) in before.items():
        if platform not in after:
            continue
        main1, whole1, wakes1 = after[platform]
        python = 100.0 * (main1 - main0) / args.window
        zenoh = 100.0 * ((whole1 - whole0) - (main1 - main0)) / args.window
        rows[platform] = {
            "cpu": round(python + zenoh, 2),
            "python": round(python, 2),
            "zenoh": round(zenoh, 2),
            "wakes_per_s": round((wakes1 - wakes0) / args.window, 1),
        }
    if not rows:
        raise SystemExit("no daemon ran through the window")
    members = [r for p, r in rows.items() if p != 1]

    def median(key: str) -> float:
        return round(statistics.median(r[key] for r in members), 2) if members else 0.0

    summary = {
        "members": len(members),
        "member_cpu": median("cpu"),
        "member_python": median("python"),
        "member_zenoh": median("zenoh"),
        "member_wakes_per_s": median("wakes_per_s"),
        "platform_1": rows.get(1),
    }
    print(json.dumps({**summary, "daemons": rows} if args.json else summary))


if __name__ == "__main__":
    main()
