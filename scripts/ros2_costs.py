#!/usr/bin/env python3
"""What ROS 2 costs a daemon, and how fast a ROS 2 message switches the swarm
(docs/benchmarks/ros2.md). Run with the ROS 2 environment's interpreter (``make
ros2-setup``), from the repository:

    .venv-ros2/bin/python scripts/ros2_costs.py idle [--seconds 30]
    .venv-ros2/bin/python scripts/ros2_costs.py latency [--size 2] [--samples 20]

``idle``: two daemons of one swarm on loopback, idle, then the same two with ``--ros2`` (a
node each, no plugin using it): per daemon, VmRSS and RssAnon from ``/proc/PID/status`` and
the CPU it used (utime + stime) over ``--seconds`` once the swarm agreed, and its threads.
``latency``: ``--size`` daemons with ``--ros2`` run a script whose actor ``Watch`` holds a
``ros2.topic_event`` plugin (``/bench/detections``, ``std_msgs/String``, data = ``person``,
scope swarm, every platform switches) and goes back to ``Watch`` 0.5 s after the switch;
this process publishes ``person`` every 1.5 s and times, on the host's monotonic clock, from
the publish to each daemon's ``transition`` line (the last platform's is the collective
switch). Prints one JSON object per measurement. ``ROS_AUTOMATIC_DISCOVERY_RANGE`` is set
to ``LOCALHOST`` and the domain to 77 unless the environment says otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
os.environ.setdefault("ROS_DOMAIN_ID", "77")

from actorswarm.daemon.launch import LocalSwarm

WATCH = """    <Actor><_P_Name>Watch{i}</_P_Name><OODAConfig><Bus><_P_Name>observe_bus</_P_Name>
      <Plugin><_P_Name>ros2.topic_event</_P_Name>
        <param key="topic" value="/bench/detections"/>
        <param key="type" value="std_msgs/msg/String"/>
        <param key="event" value="seen_event"/><param key="scope" value="swarm"/>
        <param key="field" value="data"/><param key="op" value="eq"/>
        <param key="value" value="person"/><param key="cooldown" value="0"/>
      </Plugin></Bus></OODAConfig></Actor>
    <Actor><_P_Name>Found{i}</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>core.emit_after</_P_Name>
        <param key="event" value="back_event"/><param key="after" value="0.5"/></Plugin>
    </Bus></OODAConfig></Actor>
"""
STEP = """    <actor name="Watch{i}"><transition name="seen_event" barrierKey="{a}" sysNum="all">
      <successor actor="Found{i}"/></transition></actor>
    <actor name="Found{i}"><transition name="back_event" barrierKey="{b}" sysNum="all">
      <successor actor="Watch{j}"/></transition></actor>
"""


def script(size: int, samples: int) -> str:
    """``samples`` rounds of Watch (a ros2.topic_event) then Found (0.5 s), each round its
    own actors and barrier keys."""
    actors = "".join(WATCH.format(i=i) for i in range(samples + 1))
    steps = "".join(STEP.format(i=i, j=i + 1, a=2 * i + 1, b=2 * i + 2) for i in range(samples))
    return (
        '<TaskScript name="ros2-latency" version="1">\n  <_ActorsConfig>\n'
        f"{actors}  </_ActorsConfig>\n  <_TaskConfig>\n{steps}  </_TaskConfig>\n"
        f'  <_PlatformActorConfig><platform id="1-{size}" actor="Watch0"/>'
        "</_PlatformActorConfig>\n</TaskScript>\n"
    )


def _proc(pid: int) -> dict[str, int]:
    fields = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "RssAnon", "Threads"):
            fields[key] = int(value.split()[0])
    stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    fields["ticks"] = int(stat[11]) + int(stat[12])  # utime + stime
    return fields


def idle(seconds: float) -> None:
    hz = os.sysconf("SC_CLK_TCK")
    for extra in ([], ["--ros2"]):
        with tempfile.TemporaryDirectory() as tmp, LocalSwarm(Path(tmp), 2, extra=extra) as swarm:
            swarm.start_all()
            swarm.wait("the swarm agreed", lambda: swarm.agreed_master() is not None, 30)
            time.sleep(2.0)
            pids = [swarm.procs[p].pid for p in swarm.platforms]
            before = [_proc(pid) for pid in pids]
            time.sleep(seconds)
            after = [_proc(pid) for pid in pids]
            for p, b, a in zip(swarm.platforms, before, after, strict=True):
                cpu = (a["ticks"] - b["ticks"]) / hz / seconds
                print(json.dumps({
                    "measure": "idle", "ros2": bool(extra), "platform": p,
                    "cpu_percent": round(100 * cpu, 2), "vmrss_mib": round(a["VmRSS"] / 1024, 1),
                    "rssanon_mib": round(a["RssAnon"] / 1024, 1), "threads": a["Threads"],
                    "seconds": seconds,
                }), flush=True)  # fmt: skip
            if extra:
                started = swarm.events(1, "started")[0]
                assert started.get("ros2"), started


def latency(size: int, samples: int) -> None:
    import asyncio

    from std_msgs.msg import String

    from actorswarm.ros2.node import RosNode

    with (
        tempfile.TemporaryDirectory() as tmp,
        LocalSwarm(Path(tmp), size, extra=["--ros2"]) as swarm,
    ):
        swarm.start_all()
        swarm.wait("the swarm agreed", lambda: swarm.agreed_master() is not None, 30)
        path = Path(tmp) / "s.xml"
        path.write_text(script(size, samples))
        state = ["--state", str(Path(tmp) / "gs.json")]
        assert swarm.gs("deploy", str(path), "--expect", str(size), *state).returncode == 0
        assert swarm.gs("start", *state).returncode == 0
        platforms = swarm.platforms
        swarm.wait(
            "Watch0 everywhere",
            lambda: all(swarm.status(p).get("actors") == ["Watch0"] for p in platforms),
        )

        async def publish() -> list[float]:
            node = RosNode("bench")
            node.start()
            out = []
            try:
                pub = node.publisher("/bench/detections", "std_msgs/msg/String")
                while pub.get_subscription_count() < size:
                    await asyncio.sleep(0.05)
                await asyncio.sleep(1.0)
                for _ in range(samples):
                    out.append(time.monotonic())
                    pub.publish(String(data="person"))
                    await asyncio.sleep(1.5)
            finally:
                node.close()
            return out

        sent = asyncio.run(publish())
        time.sleep(0.5)
        if os.environ.get("ROS2_COSTS_DEBUG"):
            for p in swarm.platforms:
                print(p, [(round(e["t"] - sent[0], 2), e["on"], e["to"])
                          for e in swarm.events(p, "transition")], file=sys.stderr)  # fmt: skip
                print(p, swarm.events(p, "ros2-error")[:3], swarm.events(p, "ignored")[:3],
                      file=sys.stderr)  # fmt: skip
        switches = {p: [e["t"] for e in swarm.events(p, "transition") if e["on"] == "seen_event"]
                    for p in swarm.platforms}  # fmt: skip
    delays = []
    for t in sent:
        each = [min((s for s in switches[p] if s > t), default=None) for p in switches]
        if all(s is not None and s - t < 1.4 for s in each):
            delays.append(max(s for s in each if s is not None) - t)
    ranked = sorted(delays)
    ranked = sorted(delays)
    print(json.dumps({
        "measure": "latency", "size": size, "samples": len(sent), "switched": len(delays),
        "median_ms": round(1000 * statistics.median(delays), 1) if delays else None,
        "p95_ms": round(1000 * ranked[math.ceil(0.95 * len(ranked)) - 1], 1) if delays else None,
        "max_ms": round(1000 * max(delays), 1) if delays else None,
    }), flush=True)  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("idle").add_argument("--seconds", type=float, default=30.0)
    lat = sub.add_parser("latency")
    lat.add_argument("--size", type=int, default=2)
    lat.add_argument("--samples", type=int, default=20)
    args = parser.parse_args()
    if args.what == "idle":
        idle(args.seconds)
    else:
        latency(args.size, args.samples)


if __name__ == "__main__":
    sys.exit(main())
