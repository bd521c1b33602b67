#!/usr/bin/env python3
"""Where one running daemon's Python spends its CPU: restart it under a profiler that
counts its main thread's CPU time, not the wall clock (docs/benchmarks/README.md, "Where a
member's time goes"). Run it while a swarm of daemons runs on this machine (``actorswarm
bench table1 --mode real``, ``actorswarm bench daemons``, ``actorswarm launch``...), with
the project's interpreter:

    .venv/bin/python scripts/daemon_profile.py --platform 7 [--seconds 60] [--top 40]

It finds the daemon started with ``--platform N``, stops it (SIGTERM: it saves its state
as on any clean stop), starts it again with the same interpreter, command line, working
directory and environment under :mod:`cProfile` timed by :func:`time.thread_time` (so a
wait in ``epoll``, ``fsync`` or for the GIL costs nothing, and Zenoh's threads are not
counted), stops it after ``--seconds`` and prints the functions that took the most of that
CPU, by their own time and with what they called. The profile is kept (``--out``, for
``python -m pstats``) and so is the restarted daemon's log (``--log``).

The restarted daemon rejoins as a new incarnation (its peers see a reboot) and runs the
script it ran from its backup; the profiler's own cost inflates every call by a similar
factor, so read the shares, not the absolute times. Start-up (imports, joining) is in the
profile too: give it a minute.
"""

from __future__ import annotations

import argparse
import os
import pstats
import signal
import subprocess
import sys
import time
from pathlib import Path

#: The profiled daemon: runs ``actorswarm`` as ``python -m actorswarm`` would, under a
#: profiler counting its main thread's CPU; the profile is written when the daemon stops.
_BOOTSTRAP = """
import cProfile, runpy, sys, time
out = sys.argv[1]
sys.argv = ["actorswarm", *sys.argv[2:]]
profile = cProfile.Profile(time.thread_time)
profile.enable()
try:
    runpy.run_module("actorswarm", run_name="__main__", alter_sys=True)
except SystemExit:
    pass
finally:
    profile.disable()
    profile.dump_stats(out)
"""


def _find(platform: int) -> tuple[int, list[str]]:
    """The PID and command line of the daemon started with ``--platform <platform>``."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            argv = [os.fsdecode(a) for a in Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")]
        except OSError:
            continue
        if "daemon" in argv and "--platform" in argv:
            at = argv.index("--platform") + 1
            if at < len(argv) and argv[at] == str(platform):
                found.append((int(pid), [a for a in argv if a]))
    if len(found) != 1:
        raise SystemExit(f"expected one daemon with --platform {platform}, found {len(found)}")
    return found[0]


def _running(pid: int) -> bool:
    """Whether ``pid`` still runs: it exists and is not a zombie (an exited daemon stays one
    until the command that started it reaps it)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2 :].split(" ", 1)[0] != "Z"


def _stop(pid: int, patience: float = 10.0) -> None:
    """SIGTERM ``pid`` and wait until it is gone."""
    os.kill(pid, signal.SIGTERM)
    until = time.monotonic() + patience
    while _running(pid):
        if time.monotonic() > until:
            raise SystemExit(f"daemon {pid} did not stop within {patience:g} s of SIGTERM")
        time.sleep(0.05)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--platform", type=int, required=True, help="the daemon to profile")
    parser.add_argument("--seconds", type=float, default=60.0, help="how long (default 60)")
    parser.add_argument("--top", type=int, default=40, help="functions listed (default 40)")
    parser.add_argument("--out", type=Path, default=Path("daemon.prof"), help="the profile")
    parser.add_argument("--log", type=Path, default=Path("daemon-profiled.log"), help="its log")
    args = parser.parse_args()
    if args.seconds <= 0 or args.top <= 0:
        parser.error("--seconds and --top must be positive")

    pid, argv = _find(args.platform)
    if "actorswarm" not in argv or argv.index("actorswarm") < 1:
        raise SystemExit(f"daemon {pid} was not started as `python -m actorswarm`: {argv}")
    python, rest = argv[0], argv[argv.index("actorswarm") + 1 :]
    cwd = os.readlink(f"/proc/{pid}/cwd")
    env: dict[str, str] = {}
    for entry in Path(f"/proc/{pid}/environ").read_bytes().split(b"\0"):
        key, sep, value = entry.partition(b"=")
        if sep:
            env[os.fsdecode(key)] = os.fsdecode(value)
    out = args.out.resolve()
    print(f"stopping platform {args.platform} (pid {pid})", file=sys.stderr)
    _stop(pid)
    with args.log.open("wb") as log:
        child = subprocess.Popen(
            [python, "-c", _BOOTSTRAP, str(out), *rest],
            cwd=cwd,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        print(f"profiling it for {args.seconds:g} s (pid {child.pid})", file=sys.stderr)
        time.sleep(args.seconds)
        child.send_signal(signal.SIGTERM)
        child.wait(timeout=30)
    if not out.exists():
        raise SystemExit(f"no profile written (the daemon's log: {args.log})")
    stats = pstats.Stats(str(out))
    cpu = sum(entry[2] for entry in stats.stats.values())  # type: ignore[attr-defined]
    print(f"main thread CPU in the profile: {cpu:.3f} s over {args.seconds:g} s")
    stats.sort_stats("tottime").print_stats(args.top)
    stats.sort_stats("cumulative").print_stats(args.top)


if __name__ == "__main__":
    main()
