#!/usr/bin/env python3
"""What a daemon costs in memory and start-up imports (docs/benchmarks/README.md, "Daemon
memory and imports"). Run with the project's interpreter, from the repository:

    .venv/bin/python scripts/daemon_memory.py imports [--runs 9]
    .venv/bin/python scripts/daemon_memory.py daemons [--size 5]
    .venv/bin/python scripts/daemon_memory.py zenoh [--peers 30] [--large] [--zenoh-defaults]
    .venv/bin/python scripts/daemon_memory.py mavlink

``imports``: a fresh interpreter imports ``actorswarm.daemon.run``: the cumulative time of
that import as ``python -X importtime`` reports it (median of ``--runs``), the number of
modules loaded and the process's VmRSS; then the same for what ``actorswarm daemon``
holds when the daemon starts serving (its whole command-line path, the daemon's run
replaced by a probe). ``daemons``: one idle daemon alone, then a swarm of ``--size``
daemons on loopback (secure, as ``actorswarm bench daemons`` runs them): VmRSS and RssAnon
from ``/proc/PID/status``, the median of four samples a second apart once the swarm agreed.
``zenoh``: Zenoh alone, ``--peers`` + 1 processes in one full mesh on loopback, each
putting 200 bytes 10 times a second (and with ``--large`` a 16 KB message every 5 s): the
memory of one of them, with the daemon's Zenoh configuration or Zenoh's defaults.

``mavlink``: one daemon alone with ``--vehicle mavlink``, flying a simulated autopilot
(``actorswarm autopilot --ready-after 0``, another process, on UDP loopback): the same
samples once the link is up.

``--src DIR`` measures the package under ``DIR/src`` instead (another checkout, e.g. the
commit before a change: ``git archive HEAD src | tar -x -C /tmp/before``). Prints one JSON
object per measurement.
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
from typing import Any

HEAVY = ("typer", "rich", "click", "numpy", "scipy", "fastapi", "matplotlib",
         "importlib.metadata", "actorswarm.dsl.checker", "actorswarm.cli.app",
         "cryptography")  # fmt: skip

_PROBE = """
import json, re, sys
import actorswarm.daemon.run as run
def probe(options):
    status = open("/proc/self/status").read()
    kib = lambda key: int(re.search(key + r":\\s+(\\d+)", status).group(1))
    print(json.dumps({"modules": len(sys.modules), "VmRSS": kib("VmRSS") / 1024,
                      "RssAnon": kib("RssAnon") / 1024,
                      "heavy": [m for m in %r if m in sys.modules]}))
    return 0
run.run_daemon = probe
sys.argv = ["actorswarm", "daemon", "--platform", "1", "--insecure", "--no-multicast",
            "--state-dir", %r]
from actorswarm.__main__ import main
try:
    main()
except SystemExit:
    pass
"""


def _env(src: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = str(src / "src")
    return env


def _status(pid: int) -> dict[str, float]:
    out: dict[str, float] = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("VmRSS", "RssAnon"):
            out[key] = int(value.split()[0]) / 1024
    return out


def _sample(pid: int, samples: int = 4) -> dict[str, float]:
    got = []
    for _ in range(samples):
        got.append(_status(pid))
        time.sleep(1.0)
    return {key: round(statistics.median(g[key] for g in got), 1) for key in got[0]}


def imports(src: Path | None, runs: int) -> dict[str, Any]:
    times, rss = [], []
    modules = 0
    code = (
        "import actorswarm.daemon.run, re, sys\n"
        "s = open('/proc/self/status').read()\n"
        "print(len(sys.modules), re.search(r'VmRSS:\\s+(\\d+)', s).group(1))\n"
    )
    for _ in range(runs):
        done = subprocess.run(
            [sys.executable, "-X", "importtime", "-c", code],
            capture_output=True, text=True, env=_env(src), check=True,
        )  # fmt: skip
        line = [
            row for row in done.stderr.splitlines()
            if row.startswith("import time:") and row.split("|")[2] == " actorswarm.daemon.run"
        ][-1]  # fmt: skip
        times.append(int(line.split("|")[1]) / 1000)
        count, kib = done.stdout.split()
        modules = int(count)
        rss.append(int(kib) / 1024)
    with tempfile.TemporaryDirectory() as state:
        probe = subprocess.run(
            [sys.executable, "-c", _PROBE % (HEAVY, state)],
            capture_output=True, text=True, env=_env(src), check=True,
        )  # fmt: skip
    return {
        "import_ms_median": round(statistics.median(times)),
        "import_ms_range": [round(min(times)), round(max(times))],
        "modules": modules,
        "VmRSS_after_import": round(statistics.median(rss), 1),
        "daemon_command_at_start": {
            k: round(v, 1) if isinstance(v, float) else v
            for k, v in json.loads(probe.stdout.strip().splitlines()[-1]).items()
        },
    }


def daemons(src: Path | None, size: int) -> dict[str, Any]:
    from actorswarm.daemon.launch import LocalSwarm

    if src is not None:
        os.environ["PYTHONPATH"] = str(src / "src")  # the daemons are started from it
    out: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as d, LocalSwarm(Path(d), 1) as alone:
        proc = alone.start(1)
        alone.wait("a status", lambda: bool(alone.status(1)), timeout=30)
        time.sleep(6)
        out["idle"] = _sample(proc.pid)
    with tempfile.TemporaryDirectory() as d, LocalSwarm(Path(d), size) as swarm:
        swarm.start_all()
        everyone = range(1, size + 1)
        swarm.wait(
            "one swarm",
            lambda: (
                swarm.agreed_master() is not None
                and all(len(swarm.status(p).get("members", [])) == size - 1 for p in everyone)
            ),
            timeout=60,
        )
        time.sleep(6)
        master = swarm.agreed_master()
        members = [p for p in everyone if p != master]
        out[f"member_of_{size}"] = _sample(swarm.procs[members[-1]].pid)
        out[f"every_member_of_{size}"] = [
            {k: round(v, 1) for k, v in _status(swarm.procs[p].pid).items()} for p in members
        ]
        out[f"master_of_{size}"] = {
            k: round(v, 1) for k, v in _status(swarm.procs[master or 1].pid).items()
        }
    return out


def mavlink(src: Path | None) -> dict[str, Any]:
    from actorswarm.daemon.launch import LocalSwarm, free_ports

    port = free_ports(1)[0]
    origin = "47.397742,8.545594,488"
    pilot = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "autopilot", "--home", origin,
         "--listen", f"udpin:127.0.0.1:{port}", "--ready-after", "0"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    if src is not None:
        os.environ["PYTHONPATH"] = str(src / "src")  # the daemon is started from it
    try:
        with tempfile.TemporaryDirectory() as d, LocalSwarm(Path(d), 1) as alone:
            proc = alone.start(
                1, "--vehicle", "mavlink", "--mavlink", f"udpout:127.0.0.1:{port}",
                "--mavlink-sysid", "1", "--origin", origin,
            )  # fmt: skip
            alone.wait(
                "the link up",
                lambda: alone.status(1).get("vehicle", {}).get("link") == "up",
                timeout=30,
            )
            time.sleep(6)
            return {"mavlink_idle": _sample(proc.pid)}
    finally:
        pilot.terminate()
        pilot.wait(timeout=10)


def _zenoh_peer(me: int, ports: list[int], extra: dict[str, Any], seconds: float) -> None:
    import zenoh

    cfg = zenoh.Config()
    settings = {
        "mode": "peer",
        "listen/endpoints": [f"tcp/127.0.0.1:{ports[me]}"],
        "connect/endpoints": [f"tcp/127.0.0.1:{p}" for p in ports[:me]],
        "scouting/multicast/enabled": False,
        "transport/link/tx/lease": 1000,
        "transport/link/tx/keep_alive": 4,
        **extra,
    }
    for key, value in settings.items():
        cfg.insert_json5(key, json.dumps(value))
    session = zenoh.open(cfg)
    heard = [0]

    def hear(sample: Any) -> None:
        heard[0] += 1
        sample.payload.to_bytes()

    session.declare_subscriber("memory/all/*", hear)
    pub = session.declare_publisher(
        f"memory/all/{me}",
        congestion_control=zenoh.CongestionControl.DROP,
        reliability=zenoh.Reliability.BEST_EFFORT,
    )
    small, large = os.urandom(200), os.urandom(16_000)
    big = os.environ.get("MEMORY_LARGE") == "1"
    end, i = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        pub.put(large if big and i % 50 == 0 else small)
        i += 1
        time.sleep(0.1)
    if me == len(ports) - 1:
        print(json.dumps({**{k: round(v, 1) for k, v in _status(os.getpid()).items()},
                          "heard": heard[0]}), flush=True)  # fmt: skip


def zenoh_mesh(peers: int, large: bool, defaults: bool) -> dict[str, Any]:
    from actorswarm.daemon.launch import free_ports
    from actorswarm.transport.zenoh_transport import SMALL_ROBOT

    ports = free_ports(peers + 1)
    extra = {} if defaults else SMALL_ROBOT
    env = {**os.environ, "MEMORY_LARGE": "1" if large else "0"}
    procs = []
    for me in range(peers + 1):
        seconds = 25 + (peers + 1 - me) * 0.3  # the last one started reports while all run
        args = [sys.executable, __file__, "zenoh-peer", str(me), json.dumps(ports),
                json.dumps(extra), str(seconds)]  # fmt: skip
        reporter = me == peers
        procs.append(
            subprocess.Popen(
                args, env=env, text=True,
                stdout=subprocess.PIPE if reporter else subprocess.DEVNULL,
            )
        )  # fmt: skip
        time.sleep(0.3)
    out = procs[-1].communicate(timeout=180)[0]
    for proc in procs:
        proc.wait(timeout=60)
    return {"peers": peers, "large": large, "config": "zenoh defaults" if defaults else
            "SMALL_ROBOT", **json.loads(out.strip().splitlines()[-1])}  # fmt: skip


def main() -> None:
    if sys.argv[1:2] == ["zenoh-peer"]:
        me, ports, extra, seconds = sys.argv[2:6]
        _zenoh_peer(int(me), json.loads(ports), json.loads(extra), float(seconds))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("what", choices=["imports", "daemons", "zenoh", "mavlink"])
    parser.add_argument("--src", type=Path, help="measure the package under SRC/src")
    parser.add_argument("--runs", type=int, default=9)
    parser.add_argument("--size", type=int, default=5)
    parser.add_argument("--peers", type=int, default=30)
    parser.add_argument("--large", action="store_true")
    parser.add_argument("--zenoh-defaults", action="store_true")
    args = parser.parse_args()
    if args.what == "imports":
        result = imports(args.src, args.runs)
    elif args.what == "daemons":
        result = daemons(args.src, args.size)
    elif args.what == "mavlink":
        result = mavlink(args.src)
    else:
        result = zenoh_mesh(args.peers, args.large, args.zenoh_defaults)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
