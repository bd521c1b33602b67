#!/usr/bin/env python3
"""What the operator sees while a booting autopilot gets ready (docs/vehicles.md, "In the
field"). Run with the project's interpreter, from the repository:

    .venv/bin/python scripts/autopilot_boot.py ardupilot|px4 [--ready-after S]

Starts ``actorswarm autopilot --kind KIND`` (its default boot unless ``--ready-after``) and
one daemon flying it, deploys and starts ``tests/daemon/lost.xml`` (take off to 5 m) at
once, prints each new ``gs status`` line (polled every 2 s) until the platform hovers, then
the daemon's ``vehicle-*`` log lines; times are seconds since the autopilot started.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from actorswarm.daemon.launch import LocalSwarm, free_ports

ORIGIN = "47.397742,8.545594,488"
SCRIPT = Path(__file__).resolve().parents[1] / "tests" / "daemon" / "lost.xml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("kind", choices=["ardupilot", "px4"])
    parser.add_argument("--ready-after", type=float)
    args = parser.parse_args()
    port = free_ports(1)[0]
    extra = [] if args.ready_after is None else ["--ready-after", str(args.ready_after)]
    t0 = time.monotonic()
    pilot = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "autopilot", "--home", ORIGIN, "--kind", args.kind,
         "--listen", f"udpin:127.0.0.1:{port}", *extra],
        stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        with tempfile.TemporaryDirectory() as d, LocalSwarm(Path(d), 1) as swarm:
            swarm.start(
                1, "--vehicle", "mavlink", "--mavlink", f"udpout:127.0.0.1:{port}",
                "--mavlink-sysid", "1", "--origin", ORIGIN,
            )  # fmt: skip
            swarm.wait(
                "the link", lambda: swarm.status(1).get("vehicle", {}).get("link") == "up", 30
            )
            state = ["--state", str(Path(d) / "gs.json")]
            swarm.gs("deploy", str(SCRIPT), "--expect", "1", *state, timeout=60)
            swarm.gs("start", *state, timeout=60)
            print(f"{time.monotonic() - t0:5.1f} s  script started")
            shown: set[str] = set()
            while swarm.status(1).get("actors") != ["Hover"]:
                line = swarm.gs("status").stdout.strip()
                reason = line.rpartition(" s — ")[2]
                if reason not in shown:
                    shown.add(reason)
                    print(f"{time.monotonic() - t0:5.1f} s  {line}")
                if time.monotonic() - t0 > 180:
                    sys.exit("not hovering after 180 s")
                time.sleep(2)
            print(f"{time.monotonic() - t0:5.1f} s  hovering at 5 m")
            for e in swarm.events(1):
                if e["event"].startswith("vehicle-") and e["event"] != "vehicle-text":
                    fields = {k: v for k, v in e.items() if k not in ("t", "event")}
                    print(f"{e['t'] - t0:5.1f} s  {e['event']} {fields}")
    finally:
        pilot.terminate()
        pilot.wait()


if __name__ == "__main__":
    main()
