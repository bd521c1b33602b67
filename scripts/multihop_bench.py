"""What a hop costs: real daemons in network namespaces, a chain of relays against one hop.

Run as root (network namespaces): ``.venv/bin/python scripts/multihop_bench.py --out
docs/benchmarks/multihop``. Two swarms of five, each platform in a namespace of its own,
built by the test suite's :mod:`netns_lab` (``tests/daemon``), 2 % of what each link end
sends lost (and delayed where the kernel has ``sch_netem``; without it, ``--proxy-delay MS``
delays every connection by that much each way, through a TCP forwarder per link):

* ``chain``: 1 — 2 — 3 — 4 — 5 — ground station, every daemon ``--relay`` (Zenoh routers);
  platform 1, the master, is four hops from platform 5;
* ``one hop``: a link between every two platforms, and between the ground station and each,
  the default mesh of Zenoh peers, no relay.

Each build deploys the branch-and-merge script (resized to five), fires ``--events`` events
alternately (branch, merge), each on a barrier of all five, then kills the master. Per
event: when each platform switched (its daemon's own ``transition`` line, the host's
monotonic clock, the same in every namespace), so the *release spread* (first to last
platform) and each platform's lag behind the master, against its hops from the master: the
slope of that lag is what one relay adds to a release. Per kill: when each survivor
followed the new master (its ``master`` line), after the SIGKILL. ``--builds`` builds of
each. Writes ``multihop.md`` and ``multihop.json`` under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform as host
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "daemon"))

from netns_lab import PREFIX, Radios, run  # noqa: E402

from actorswarm.daemon.launch import LocalSwarm  # noqa: E402

SIZE = 5
PORT = 7447
BRANCH, MERGE = "AtoBC_branch_event", "finish_event"


def _impairment() -> str:
    probe = f"{PREFIX}{os.getpid()}-probe"
    run("ip", "netns", "add", probe)
    try:
        run("ip", "-n", probe, "link", "add", "q0", "type", "veth", "peer", "name", "q1")
        done = run("ip", "netns", "exec", probe, "tc", "qdisc", "add", "dev", "q0", "root",
                   "netem", "delay", "1ms")  # fmt: skip
        return "netem" if done.returncode == 0 else "nftables"
    finally:
        run("ip", "netns", "del", probe)


def _script(directory: Path) -> Path:
    text = (ROOT / "examples" / "branch_merge.xml").read_text()
    for old, new in (('sysNum="10"', f'sysNum="{SIZE}"'), ('cnt="8"', f'cnt="{SIZE - 2}"'),
                     ('sysNum="8"', f'sysNum="{SIZE - 2}"')):  # fmt: skip
        text = text.replace(old, new)
    path = directory / "branch_merge_5.xml"
    path.write_text(text)
    return path


def _gs(swarm: LocalSwarm, *args: str) -> str:
    done = swarm.gs(*args, timeout=60)
    if done.returncode != 0:
        raise RuntimeError(f"gs {' '.join(args)}: {done.stdout}{done.stderr}")
    return done.stdout


def build(
    kind: str, impairment: str, events: int, directory: Path, proxy_delay: float = 0.0
) -> dict[str, Any]:
    """One build of ``kind`` ("chain" or "one hop"): its switches and its failover."""
    radios = Radios(f"{PREFIX}{os.getpid()}", impairment, 2, 10, proxy_delay_ms=proxy_delay)
    try:
        everyone = list(range(1, SIZE + 1))
        if kind == "chain":
            for p in range(1, SIZE):
                radios.link(p, p + 1)
            radios.link(0, SIZE)
            hops = {p: p - 1 for p in everyone}
            gs_at = [SIZE]
        else:
            for a in everyone:
                for b in everyone:
                    if a < b:
                        radios.link(a, b)
                radios.link(0, a)
            hops = dict.fromkeys(everyone, 1)
            hops[1] = 0
            gs_at = everyone
        links = radios.connects(everyone, PORT)
        with LocalSwarm(
            directory / "swarm",
            SIZE,
            endpoints=[f"tcp/0.0.0.0:{PORT}"] * SIZE,
            links=links,
            gs_connect=[radios.via(0, p, PORT) for p in gs_at],
            wrap=radios.wrap,
            relay=kind == "chain",
        ) as swarm:
            swarm.start_all()
            swarm.wait("master 1", lambda: swarm.agreed_master(everyone) == 1, timeout=45)
            state = ["--state", str(directory / "gs.json")]
            _gs(swarm, "deploy", str(_script(directory)), "--expect", f"1-{SIZE}", *state)
            _gs(swarm, "start", *state)
            swarm.wait(
                "A everywhere",
                lambda: all(swarm.status(p).get("actors") == ["A"] for p in everyone),
            )
            switches = []
            for i in range(events):
                event = BRANCH if i % 2 == 0 else MERGE
                before = {p: len(swarm.events(p, "transition")) for p in everyone}
                heard = {p: len(swarm.events(p, "command")) for p in everyone}
                _gs(swarm, "event", event, "--platforms", f"1-{SIZE}")

                def switched(before: dict[int, int] = before) -> bool:
                    return all(len(swarm.events(p, "transition")) > before[p] for p in everyone)

                swarm.wait(f"{event} everywhere", switched, timeout=30)
                at = {p: float(swarm.events(p, "transition")[before[p]]["at"]) for p in everyone}
                causes = {swarm.events(p, "transition")[before[p]]["cause"] for p in everyone}
                # When each platform took the operator's event in (its daemon's `command`
                # line): the first of them starts the collective switch.
                got = {
                    p: min(
                        float(e["at"])
                        for e in swarm.events(p, "command")[heard[p] :]
                        if e.get("on") == event
                    )
                    for p in everyone
                }
                switches.append({"event": event, "at": at, "got": got, "causes": sorted(causes)})
                time.sleep(0.3)
            killed = time.monotonic()
            swarm.stop(1, signal.SIGKILL)
            survivors = everyone[1:]
            swarm.wait("master 2", lambda: swarm.agreed_master(survivors) == 2, timeout=20)
            follow = {}
            for p in survivors:
                lines = [e["t"] for e in swarm.events(p, "master")
                         if e.get("master") == 2 and e["t"] > killed]  # fmt: skip
                follow[p] = min(lines) - killed
        lost, offered = radios.drops()
        return {"kind": kind, "hops": hops, "switches": switches, "follow": follow,
                "lost": lost, "offered": offered}  # fmt: skip
    finally:
        radios.teardown()


def _slope(points: list[tuple[int, float]]) -> float:
    xs = [x for x, _ in points]
    ys = [y for _, y in points]
    mx, my = statistics.fmean(xs), statistics.fmean(ys)
    den = sum((x - mx) ** 2 for x in xs)
    return sum((x - mx) * (y - my) for x, y in points) / den if den else 0.0


def _fmt(values: list[float]) -> str:
    ordered = sorted(values)
    p95 = ordered[min(len(ordered) - 1, round(0.95 * (len(ordered) - 1)))]
    return (f"{statistics.median(ordered) * 1000:.1f} / {p95 * 1000:.1f} "
            f"({ordered[0] * 1000:.1f}–{ordered[-1] * 1000:.1f})")  # fmt: skip


def report(
    builds: list[dict[str, Any]], command: str, impairment: str, proxy_delay: float = 0.0
) -> str:
    if proxy_delay:
        how = (
            f"sends lost ({impairment}), and every link delayed {proxy_delay:g} ms each way by "
            "a TCP forwarder in the connecting namespace (this kernel has no `sch_netem`; "
            "the forwarder acknowledges TCP at once, so only the data is late)."
        )
    elif impairment == "netem":
        how = "sends lost and 10 ms delay (netem)."
    else:
        how = (
            "sends lost (nftables); **no delay emulated**: this kernel has no `sch_netem`, "
            "so what a hop costs here is the relays' own time, not the radio's."
        )
    lines = [
        "# What a hop costs: a chain of relays against one hop (`scripts/multihop_bench.py`)",
        "",
        f"Command: `{command}`, {time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime())}.",
        "",
        f"Machine: {host.machine()}, {os.cpu_count()} CPU(s), Linux {host.release()}, "
        f"Python {host.python_version()}.",
        "",
        "Five daemons, each in a network namespace of its own, 2 % of what every link end " + how,
        "*chain*: 1 — 2 — 3 — 4 — 5 — ground station, every daemon `--relay`; *one hop*: "
        "every pair linked, Zenoh peers (the default mesh). Platform 1 is master.",
        "",
        "*Switch*: the first platform taking the operator's event in to the last one "
        "switching (the paper's collective switch; the ground station is at platform 5, so "
        "on the chain the event crosses the hops to the master before its barrier can be "
        "released). *Spread*: first to last platform's switch on one barrier release. "
        "*Lag per hop*: "
        "the slope of each platform's switch after the master's against its hops from the "
        "master (least squares over every switch). *Follow*: SIGKILL of the master to "
        "each survivor's line naming the new one. median / p95 (min–max), ms.",
        "",
        "| topology | builds | switches | switch, ms | spread, ms | lag per hop, ms | "
        "follow, ms | farthest follows, ms | packets lost |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for kind in ("one hop", "chain"):
        mine = [b for b in builds if b["kind"] == kind]
        if not mine:
            continue
        spreads, points, follows, farthest, whole = [], [], [], [], []
        for b in mine:
            for s in b["switches"]:
                at = {int(p): t for p, t in s["at"].items()}
                spreads.append(max(at.values()) - min(at.values()))
                whole.append(max(at.values()) - min(s["got"].values()))
                points += [(b["hops"][p], at[p] - at[1]) for p in at]
            follow = {int(p): t for p, t in b["follow"].items()}
            follows += list(follow.values())
            farthest.append(max(follow.values()))
        lost = sum(b["lost"] for b in mine)
        offered = sum(b["offered"] for b in mine)
        slope = _slope(points) * 1000 if kind == "chain" else float("nan")
        lines.append(
            f"| {kind} | {len(mine)} | {len(spreads)} | {_fmt(whole)} | {_fmt(spreads)} | "
            f"{'—' if kind != 'chain' else f'{slope:.2f}'} | {_fmt(follows)} | "
            f"{_fmt(farthest)} | {lost} of {offered} |"
        )
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--builds", type=int, default=3)
    parser.add_argument("--events", type=int, default=10)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument(
        "--proxy-delay",
        type=float,
        default=0.0,
        metavar="MS",
        help="delay every link this many ms each way (a TCP forwarder)",
    )
    args = parser.parse_args()
    if os.geteuid() != 0:
        print("network namespaces need root", file=sys.stderr)
        return 2
    impairment = _impairment()
    builds = []
    for i in range(args.builds):
        for kind in ("one hop", "chain"):
            with tempfile.TemporaryDirectory() as tmp:
                print(f"build {i + 1}/{args.builds}: {kind}", file=sys.stderr, flush=True)
                builds.append(build(kind, impairment, args.events, Path(tmp), args.proxy_delay))
    args.out.mkdir(parents=True, exist_ok=True)
    command = "sudo .venv/bin/python scripts/multihop_bench.py " + " ".join(sys.argv[1:])
    (args.out / "multihop.json").write_text(json.dumps(builds, indent=1) + "\n")
    (args.out / "multihop.md").write_text(report(builds, command, impairment, args.proxy_delay))
    print((args.out / "multihop.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
