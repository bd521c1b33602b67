#!/usr/bin/env python3
"""How long a ground-station command takes over lossy radio links, phase by phase.

Run as root, from the repository:
``.venv/bin/python scripts/gs_latency.py [--platforms 10] [--loss 20] [--runs 15]``.

``--platforms`` daemons (secure, mesh) in network namespaces (the test suite's
:mod:`netns_lab`, ``tests/daemon``), every pair of them linked and the ground station linked
to each, every link end losing ``--loss`` % of what it sends (``tc netem``, or nftables
where the kernel has no ``sch_netem``). Once they agree on a master, ``gs deploy`` sends
``--script``; then ``--runs`` times a ground-station session in the ground station's
namespace (the ``gs`` commands' own :class:`~actorswarm.daemon.ground.GroundSession`) opens,
deploys the script again (a platform that has it confirms at once) and closes, timing
each phase: Zenoh's open, every platform's confirmation, and the close (until the
session's end returns). Then ``--runs`` whole ``gs deploy`` commands, from start to exit;
with ``--before SRC`` alternating with as many run from the package under ``SRC/src``
(another checkout, e.g. ``git worktree add /tmp/before HEAD~1``). Prints each run, then
the median, lowest and highest of each figure.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "daemon"))

from netns_lab import full_mesh, lab_radios  # noqa: E402

from actorswarm.daemon.launch import LocalSwarm  # noqa: E402

PORT = 7447

#: One ground-station session, run in the ground station's namespace: prints its phases.
_SESSION = """
import asyncio, json, sys, time
from pathlib import Path
from actorswarm.cli.swarm_options import LinkOptions
swarm, keys, script, expect, timeout, *endpoints = sys.argv[1:]
platforms = [int(p) for p in expect.split(",")]
link = LinkOptions(swarm=swarm, connect=endpoints, multicast=False, keys=Path(keys)).link()
data = Path(script).read_bytes()
out = {}
async def go():
    began = time.monotonic()
    async with link.session(float(timeout)) as gs:
        out["open_s"] = time.monotonic() - began
        began = time.monotonic()
        sha = gs.do(lambda st, now: st.deploy(data, platforms, now))
        await gs.wait_for(lambda: not gs.station.missing(sha), float(timeout))
        out["confirm_s"] = time.monotonic() - began
        out["missing"] = gs.station.missing(sha)
        began = time.monotonic()
    out["close_s"] = time.monotonic() - began
asyncio.run(go())
print(json.dumps(out))
"""

PHASES = {"open_s": "Zenoh open", "confirm_s": "every confirmation", "close_s": "close"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--platforms", type=int, default=10)
    parser.add_argument("--loss", type=float, default=20.0, help="percent lost per link end")
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--timeout", type=float, default=30.0)
    parser.add_argument("--script", type=Path, default=ROOT / "examples" / "branch_merge.xml")
    parser.add_argument("--before", type=Path, help="a checkout to time the command of too")
    args = parser.parse_args()
    if not 2 <= args.platforms <= 20 or not 0 <= args.loss < 100 or args.runs < 1:
        parser.error("--platforms 2-20, --loss 0-99, --runs at least 1")
    if not args.script.is_file():
        parser.error(f"{args.script}: no such file")
    if args.before is not None and not (args.before / "src" / "actorswarm").is_dir():
        parser.error(f"{args.before}: no src/actorswarm there")
    try:
        radios = lab_radios(args.loss)
    except RuntimeError as exc:
        print(f"cannot run: {exc}", file=sys.stderr)
        return 2
    everyone = list(range(1, args.platforms + 1))
    rows: list[dict[str, float]] = []
    commands: dict[str, list[float]] = {}
    try:
        with (
            tempfile.TemporaryDirectory() as tmp,
            full_mesh(radios, Path(tmp), args.platforms, PORT, ground=True) as swarm,
        ):
            swarm.start_all()
            swarm.wait("a master", lambda: swarm.agreed_master(everyone) is not None, timeout=60)
            state = ["--state", str(Path(tmp) / "gs.json")]
            first = swarm.gs("deploy", str(args.script.resolve()), "--expect",
                             f"1-{args.platforms}", "--timeout", str(args.timeout), *state,
                             timeout=args.timeout + 60)  # fmt: skip
            print(f"first deploy: {first.stdout.strip()} {first.stderr.strip()}", flush=True)
            session = [sys.executable, "-c", _SESSION, swarm.swarm, str(swarm.keys),
                       str(args.script.resolve()), ",".join(map(str, everyone)),
                       str(args.timeout), *(radios.via(0, p, PORT) for p in everyone)]  # fmt: skip
            for i in range(args.runs):
                done = subprocess.run(
                    [*radios.wrap(0), *session],
                    capture_output=True,
                    text=True,
                    timeout=args.timeout + 60,
                    check=False,
                )
                if done.returncode != 0:
                    print(f"run {i + 1}: exit {done.returncode}: {done.stderr.strip()[-300:]}")
                    continue
                row = json.loads(done.stdout.strip().splitlines()[-1])
                rows.append(row)
                said = " ".join(f"{PHASES[k]} {row[k]:.2f} s" for k in PHASES)
                missing = f", not confirmed by {row['missing']}" if row["missing"] else ""
                print(f"run {i + 1}: {said}{missing}", flush=True)
            sources = {"command": None} if args.before is None else {
                "command (before)": args.before / "src", "command": None}  # fmt: skip
            for i in range(args.runs):
                for label, src in sources.items():
                    took = _command(swarm, src, args, state)
                    commands.setdefault(label, []).append(took)
                    print(f"{label} {i + 1}: {took:.2f} s", flush=True)
    finally:
        radios.teardown()
    print(f"{args.platforms} platforms, {radios.describe()}; {len(rows)} sessions:")
    figures = {label: [r[key] for r in rows] for key, label in PHASES.items()}
    figures |= {f"whole gs deploy, {label}": values for label, values in commands.items()}
    for label, values in figures.items():
        if values:
            print(f"  {label}: median {statistics.median(values):.2f} s "
                  f"(min {min(values):.2f}, max {max(values):.2f})")  # fmt: skip
    return 0


def _command(
    swarm: LocalSwarm, src: Path | None, args: argparse.Namespace, state: list[str]
) -> float:
    """The wall time of one ``gs deploy`` (the package under ``src``, or this one)."""
    saved = os.environ.get("PYTHONPATH")
    if src is not None:
        os.environ["PYTHONPATH"] = str(src)
    try:
        began = time.monotonic()
        done = swarm.gs("deploy", str(args.script.resolve()), "--expect",
                        f"1-{args.platforms}", "--timeout", str(args.timeout), *state,
                        timeout=args.timeout + 60)  # fmt: skip
        took = time.monotonic() - began
    finally:
        if saved is None:
            os.environ.pop("PYTHONPATH", None)
        else:
            os.environ["PYTHONPATH"] = saved
    if done.returncode != 0:
        print(f"  (exit {done.returncode}: {done.stderr.strip()[-200:]})")
    return took


if __name__ == "__main__":
    raise SystemExit(main())
