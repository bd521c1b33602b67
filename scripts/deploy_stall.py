#!/usr/bin/env python3
"""How long a deploy holds up a daemon's event loop (docs/benchmarks/README.md, "A deploy
and the daemon's loop"). Run with the project's interpreter, from the repository:

    .venv/bin/python scripts/deploy_stall.py [--runs 9] [--hogs N] [--on-loop] [--script FILE]

Each run starts a daemon in a fresh interpreter of its own, beside a probe of its event
loop, and deploys ``--script`` (default: ``examples/branch_merge.xml``) to it with ``gs
deploy`` (:mod:`actorswarm.bench.deploy_stall`). ``--hogs N`` keeps N processes spinning
on the CPU meanwhile (a loaded machine); ``--on-loop`` makes the same check on the
daemon's loop instead of in a child (the comparison: what the child spares the loop).
Prints each run, then the median, lowest and highest of: the loop's longest stall during
the deploy, the check's time, and the probe's wake-ups during the check; as JSON with
``--json``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_ONE = """
import json, sys
from pathlib import Path
from actorswarm.bench.deploy_stall import deploy_beside_probe
from actorswarm.dsl.isolated import check_isolated, check_isolated_async
async def on_loop(text, path, *, timeout):  # the comparison: the same check, on the loop
    return check_isolated(text, path, timeout=timeout)
check = on_loop if sys.argv[3] == "loop" else check_isolated_async
run = deploy_beside_probe(Path(sys.argv[1]), Path(sys.argv[2]), check=check)
print(json.dumps({"code": run.code, "checks": len(run.checks), "worst_ms": run.worst * 1000,
                  "check_ms": run.check_s * 1000, "wakes_during_check": run.wakes_during_check()}))
"""


def _spin() -> None:
    while True:
        pass


def one(script: Path, *, on_loop: bool = False) -> dict[str, float]:
    """One deploy beside the probe, in a fresh interpreter (the daemon's signal handling
    and Zenoh's threads stay out of this process); ``on_loop``: the check made on the
    daemon's loop instead of in its child (what the child spares the loop)."""
    where = "loop" if on_loop else "child"
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run(
            [sys.executable, "-c", _ONE, str(script), str(Path(tmp) / "state"), where],
            capture_output=True, text=True, timeout=120, check=False, cwd=ROOT,
        )  # fmt: skip
    if done.returncode != 0:
        raise SystemExit(f"a run failed ({done.returncode}):\n{done.stderr[-2000:]}")
    row: dict[str, float] = json.loads(done.stdout.strip().splitlines()[-1])
    if row["code"] != 0 or row["checks"] != 1:
        raise SystemExit(f"the deploy did not complete as it should: {row}")
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--hogs", type=int, default=0, help="CPU-bound processes beside")
    parser.add_argument("--script", type=Path, default=ROOT / "examples" / "branch_merge.xml")
    parser.add_argument(
        "--on-loop", action="store_true", help="the check on the daemon's loop (for comparison)"
    )
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.runs < 1 or args.hogs < 0:
        parser.error("--runs must be at least 1 and --hogs at least 0")
    if not args.script.is_file():
        parser.error(f"{args.script}: no such file")
    hogs = [multiprocessing.Process(target=_spin, daemon=True) for _ in range(args.hogs)]
    for hog in hogs:
        hog.start()
    rows = []
    try:
        for i in range(args.runs):
            rows.append(one(args.script.resolve(), on_loop=args.on_loop))
            if not args.json:
                r = rows[-1]
                print(
                    f"run {i + 1}: stall {r['worst_ms']:.1f} ms, check {r['check_ms']:.0f} ms, "
                    f"{r['wakes_during_check']:.0f} wake-ups during the check",
                    flush=True,
                )
    finally:
        for hog in hogs:
            hog.terminate()
    summary = {
        key: {"median": statistics.median(r[key] for r in rows),
              "min": min(r[key] for r in rows), "max": max(r[key] for r in rows)}
        for key in ("worst_ms", "check_ms", "wakes_during_check")
    }  # fmt: skip
    report = {"runs": args.runs, "hogs": args.hogs, "cpus": multiprocessing.cpu_count(),
              "script": args.script.name, "on_loop": args.on_loop, **summary}  # fmt: skip
    if args.json:
        print(json.dumps(report))
    else:
        labels = {
            "worst_ms": "longest stall of the loop, ms",
            "check_ms": "the check, ms",
            "wakes_during_check": "wake-ups of the probe during the check",
        }
        for key, label in labels.items():
            s = summary[key]
            print(f"{label}: median {s['median']:.1f} (min {s['min']:.1f}, max {s['max']:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
