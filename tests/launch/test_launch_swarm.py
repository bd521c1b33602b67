"""``actorswarm launch`` end to end: a launch file starts three daemons on loopback, the
ground station deploys to them, starts and switches them, one is restarted on request,
and SIGINT stops them all cleanly, leaving no daemon behind."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from tests.launch.output import LauncherOutput

from actorswarm.daemon.launch import LocalSwarm, free_ports
from actorswarm.security import init_keys

SCRIPT = Path(__file__).resolve().parents[1] / "daemon" / "three.xml"


def _get(url: str, timeout: float = 20.0) -> str:
    """The page at ``url``, once the server answers."""
    end = time.monotonic() + timeout
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2) as reply:
                return str(reply.read().decode())
        except OSError:
            if time.monotonic() > end:
                raise
            time.sleep(0.2)


def test_a_launch_file_starts_a_swarm_the_ground_station_drives_and_sigint_stops(
    tmp_path: Path,
) -> None:
    keys = tmp_path / "keys"
    init_keys(keys)
    ports = free_ports(4)  # three daemons and the web ground station
    swarm_name = f"launch{os.getpid()}"
    path = tmp_path / "three.toml"
    path.write_text(
        f'swarm = "{swarm_name}"\nplatforms = "1-3"\nkeys = "keys"\ndirectory = "run"\n'
        f"ports = {ports[:3]}\nweb = {ports[3]}\n"
    )
    launcher = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "launch", str(path), "--interval", "0.5"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    out = LauncherOutput(launcher)
    try:
        pids = {int(out.wait_for(rf"platform {p}: pid (\d+)").group(1)) for p in (1, 2, 3)}
        out.wait_for(r"3 of 3 up, master \d")
        # The web ground station serves its page beside the swarm.
        out.wait_for(rf"web ground station: http://127.0.0.1:{ports[3]}/")
        gs_page = f"http://127.0.0.1:{ports[3]}/"
        page = _get(gs_page)
        assert "<html" in page.lower()
        # The ground station's view of the same swarm: its endpoints, keys, state directories.
        gs = LocalSwarm(
            tmp_path / "gs",
            3,
            swarm=swarm_name,
            endpoints=[f"tcp/127.0.0.1:{p}" for p in ports[:3]],
            keys=keys,
            state_dirs={p: tmp_path / "run" / f"state-{p}" for p in (1, 2, 3)},
        )
        state = ["--state", str(tmp_path / "gs.json")]
        deployed = gs.gs("deploy", str(SCRIPT), "--expect", "3", *state)
        assert deployed.returncode == 0, deployed.stdout + deployed.stderr
        started = gs.gs("start", *state)
        assert started.returncode == 0, started.stdout + started.stderr
        fired = gs.gs("event", "go_event")
        assert fired.returncode == 0, fired.stdout + fired.stderr
        gs.wait(
            "every platform in B",
            lambda: all(gs.status(p).get("actors") == ["B"] for p in (1, 2, 3)),
        )
        # A restart on request: platform 2 stops cleanly and comes back in a new
        # incarnation, in the actor it ran.
        assert launcher.stdin is not None
        launcher.stdin.write("r 2\n")
        launcher.stdin.flush()
        out.wait_for(r"platform 2 stopped \(exit 0\)")
        out.wait_for(r"platform 2: pid", count=2)
        pids |= {int(m) for m in re.findall(r"platform 2: pid (\d+)", "".join(out.lines))}
        assert len(pids) == 4  # the three first daemons and platform 2's new one
        gs.wait(
            "platform 2 back in B",
            lambda: gs.status(2).get("incarnation") == 1 and gs.status(2).get("actors") == ["B"],
        )
        launcher.send_signal(signal.SIGINT)
        assert launcher.wait(timeout=30) == 0, "".join(out.lines)
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
    for p in (1, 2, 3):
        out.wait_for(rf"platform {p}: stopped, exit 0")
    out.wait_for(r"web ground station: stopped, exit 130")  # its exit on Ctrl-C
    for pid in pids:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        raise AssertionError(f"daemon {pid} is still running")
    for p in (1, 2, 3):
        log = (tmp_path / "run" / f"daemon-{p}.log").read_text()
        assert '"event": "stopped"' in log, log[-600:]
    assert not (tmp_path / "run" / "launch.pid").exists()
