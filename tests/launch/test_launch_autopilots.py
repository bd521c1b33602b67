"""``actorswarm launch`` with autopilots: one per platform started from the file's command
template (here ``actorswarm autopilot``, as ArduPilot's or PX4's SITL would be), each
daemon's link to its own, the links reported, an autopilot that died started again with
``r ID``, and every autopilot stopped with the swarm."""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from tests.launch.output import LauncherOutput

from actorswarm.daemon.launch import free_ports
from actorswarm.launch import LaunchError, load_launch
from actorswarm.launch.autopilots import Autopilots

ORIGIN = "47.397742,8.545594,488"
COMMAND = (
    "actorswarm autopilot --listen tcpin:127.0.0.1:{port} --sysid {sysid} --home {home} "
    "--ready-after 1"
)


def _file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "sitl.toml"
    path.write_text(body)
    return path


def test_the_autopilot_table_makes_each_daemon_s_link_and_command(tmp_path: Path) -> None:
    path = _file(
        tmp_path,
        f'platforms = "3-5"\ninsecure = true\nvehicle = "mavlink"\norigin = "{ORIGIN}"\n'
        "[autopilot]\n"
        'command = "arducopter -S -I{i} --model + --sysid {sysid} --home {home},0"\n'
        'mavlink = "tcp:127.0.0.1:{port}"\nport = 5760\nport_step = 10\nspacing = 5\n',
    )
    plan = load_launch(path)
    assert plan.autopilots is not None and plan.mavlink_platforms() == [3, 4, 5]
    args = plan.daemon_args(plan.plans[2])
    assert args == ["--vehicle", "mavlink", "--mavlink", "tcp:127.0.0.1:5780",
                    "--mavlink-sysid", "5", "--origin", "47.397742,8.545594,488.0"]  # fmt: skip
    argv = plan.autopilots.argv(2, 5)
    assert argv is not None and argv[:4] == ["arducopter", "-S", "-I2", "--model"]
    lat, lon, alt, heading = argv[-1].split(",")
    assert argv[-4:-2] == ["--sysid", "5"] and (float(alt), heading) == (488.0, "0")
    east = (float(lon) - 8.545594) * 111_320 * 0.6769  # metres east at 47.4 degrees
    assert float(lat) == pytest.approx(47.397742) and east == pytest.approx(10.0, abs=0.05)
    # Without a command: attach to autopilots already running.
    attach = _file(
        tmp_path,
        f'platforms = "1-2"\nvehicle = "mavlink"\norigin = "{ORIGIN}"\n'
        '[autopilot]\nmavlink = "udpin:0.0.0.0:{port}"\nport = 14540\nport_step = 1\n',
    )
    plan = load_launch(attach)
    assert plan.autopilots is not None and plan.autopilots.argv(0, 1) is None
    assert plan.daemon_args(plan.plans[1])[3] == "udpin:0.0.0.0:14541"


def test_each_autopilot_may_run_in_a_directory_of_its_own(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``workdir = true``: each in DIRECTORY/autopilot-ID/ (a SITL's eeprom.bin, logs and
    terrain its own); ``{here}`` names the launch's own directory for its files."""
    monkeypatch.chdir(tmp_path)
    path = _file(
        tmp_path,
        f'platforms = "1-2"\ninsecure = true\ndirectory = "run"\nvehicle = "mavlink"\n'
        f'origin = "{ORIGIN}"\n[autopilot]\n'
        'command = "arduplane -I{i} --defaults {here}/plane.parm,{here}/mine.parm"\n'
        'mavlink = "tcp:127.0.0.1:{port}"\nworkdir = true\n',
    )
    plan = load_launch(path)
    assert plan.autopilots is not None and plan.autopilots.workdir
    argv = plan.autopilots.argv(1, 2)
    assert argv == ["arduplane", "-I1", "--defaults", f"{tmp_path}/plane.parm,{tmp_path}/mine.parm"]
    pilots = Autopilots(plan.autopilots, [1, 2], tmp_path / "run")
    assert pilots.workdir(2) == tmp_path / "run" / "autopilot-2"
    off = Autopilots(dataclasses.replace(plan.autopilots, workdir=False), [1, 2], tmp_path)
    assert off.workdir(2) is None


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ('vehicle = "mavlink"\n[autopilot]\nmavlink = "tcp:h:{port}"\n', "origin: missing"),
        (f'vehicle = "mavlink"\norigin = "{ORIGIN}"\n', "autopilot.mavlink: missing"),
        (
            f'vehicle = "mavlink"\norigin = "{ORIGIN}"\n[autopilot]\nmavlink = "tcp:h:{{prot}}"\n',
            "autopilot.mavlink: 'tcp:h:{prot}': bad placeholder 'prot'; the placeholders are",
        ),
        (
            f'vehicle = "mavlink"\norigin = "{ORIGIN}"\n[autopilot]\nmavlink = "x"\nspeed = 2\n',
            "autopilot.speed: unknown key",
        ),
        (
            f'vehicle = "mavlink"\norigin = "{ORIGIN}"\n[autopilot]\nmavlink = "x"\nworkdir = 1\n',
            "autopilot.workdir: expected true or false, not 1",
        ),
        ('origin = "47,8,1"\n', 'origin: for autopilots: say vehicle = "mavlink" too'),
        (f'vehicle = "boat"\norigin = "{ORIGIN}"\n', "the vehicles are: none, sim, mavlink"),
    ],
)
def test_a_bad_autopilot_table_is_refused_by_name(tmp_path: Path, body: str, message: str) -> None:
    path = _file(tmp_path, 'platforms = "1-2"\ninsecure = true\n' + body)
    with pytest.raises(LaunchError) as caught:
        load_launch(path)
    assert message in str(caught.value) and str(path) in str(caught.value)


def test_launch_starts_an_autopilot_per_platform_restarts_a_dead_one_and_stops_them(
    tmp_path: Path,
) -> None:
    ports = free_ports(4)
    low, high = sorted(ports[2:])  # the two autopilots' ports: low + i × (high - low)
    path = _file(
        tmp_path,
        f'swarm = "ap{os.getpid()}"\nplatforms = "1-2"\ninsecure = true\ndirectory = "run"\n'
        f'ports = {ports[:2]}\nvehicle = "mavlink"\norigin = "{ORIGIN}"\n'
        f'[autopilot]\ncommand = "{COMMAND}"\nmavlink = "tcp:127.0.0.1:{{port}}"\n'
        f"port = {low}\nport_step = {high - low}\n",
    )
    launcher = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "launch", str(path), "--interval", "0.3"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    out = LauncherOutput(launcher)
    pilots: set[int] = set()
    try:
        for p in (1, 2):
            pilots.add(int(out.wait_for(rf"platform {p}: autopilot pid (\d+)").group(1)))
            out.wait_for(rf"platform {p}: autopilot link up after [\d.]+ s")
        first = int(out.wait_for(r"platform 2: autopilot pid (\d+)").group(1))
        os.kill(first, signal.SIGKILL)  # the autopilot of platform 2 dies
        out.wait_for(r"platform 2: its autopilot exited with status -9: `r 2` starts it")
        assert launcher.stdin is not None
        launcher.stdin.write("r 2\n")
        launcher.stdin.flush()
        again = int(out.wait_for(r"platform 2: autopilot pid (\d+)", count=2).group(1))
        again = max(
            int(m) for m in re.findall(r"platform 2: autopilot pid (\d+)", "".join(out.lines))
        )
        assert again != first
        pilots.add(again)
        out.wait_for(r"platform 2: autopilot link up after", count=2)
        launcher.send_signal(signal.SIGINT)
        assert launcher.wait(timeout=40) == 0, "".join(out.lines)
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
    for p in (1, 2):
        out.wait_for(rf"platform {p}: autopilot stopped, exit 0")
    for pid in pilots - {first}:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        raise AssertionError(f"autopilot {pid} is still running")
    assert "autopilot 2 (ardupilot) on tcpin" in (tmp_path / "run" / "autopilot-2.log").read_text()


@pytest.mark.parametrize(
    ("launch", "script", "platforms"),
    [
        ("formation-arduplane.toml", "formation_arduplane.xml", "1-10"),
        ("formation-arduplane-30.toml", "formation_arduplane_30.xml", "1-30"),
    ],
)
def test_the_fixed_wing_launch_file_flies_simulated_arduplanes(
    tmp_path: Path, launch: str, script: str, platforms: str
) -> None:
    """The fixed-wing launch files as shipped (ten and thirty aircraft), with `actorswarm
    autopilot --frame plane` for the SITL binary and two platforms: the daemons pass
    ArduPlane's failsafe check (SYSID_MYGCS), set each aircraft's take-off altitude on its
    layer and arm it in TAKEOFF."""
    import json
    import time

    root = Path(__file__).resolve().parents[2]
    shipped = (root / "examples" / "launch" / launch).read_text()
    ports = free_ports(4)
    low, high = sorted(ports[2:])
    swarm = f"fw{os.getpid()}"
    directory = next(line for line in shipped.splitlines() if line.startswith("directory = "))
    assert f'platforms = "{platforms}"' in shipped
    body = (
        shipped.replace(
            'swarm = "formation-arduplane"', f'swarm = "fw{os.getpid()}"\ninsecure = true'
        )
        .replace(f'platforms = "{platforms}"', 'platforms = "1-2"')
        .replace(directory, 'directory = "run"')
        .replace("ports = 7601", f"ports = {ports[:2]}")
        .replace(
            'config = "formation-arduplane-daemon.toml"',
            f'config = "{root / "examples" / "launch" / "formation-arduplane-daemon.toml"}"',
        )
    )
    template = next(line for line in body.splitlines() if line.startswith("command = "))
    assert "arduplane" in template and "{home},90" in template
    body = body.replace(
        template,
        'command = "actorswarm autopilot --frame plane --listen tcpin:127.0.0.1:{port} '
        '--sysid {sysid} --home {home},90 --ready-after 2"',
    )
    body = body.replace("port = 5760", f"port = {low}").replace(
        "port_step = 10", f"port_step = {high - low}"
    )
    path = _file(tmp_path, body)
    launcher = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "launch", str(path), "--interval", "0.3"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    out = LauncherOutput(launcher)
    gs = ["--swarm", swarm, "--insecure", "--no-multicast"]
    gs += ["--connect", f"tcp/127.0.0.1:{ports[0]}"]

    def vehicle(p: int) -> dict[str, object]:
        try:
            state = json.loads((tmp_path / "run" / f"state-{p}" / "status.json").read_text())
        except (OSError, ValueError):
            return {}
        return state.get("vehicle") or {}

    try:
        for p in (1, 2):
            out.wait_for(rf"platform {p}: autopilot link up after [\d.]+ s")
            # Each in a directory of its own (workdir): a SITL's eeprom.bin is its own.
            assert (tmp_path / "run" / f"autopilot-{p}").is_dir()
        script = str(root / "examples" / script)
        for command in (["deploy", script, "--expect", "2"], ["start"]):
            done = subprocess.run(
                [sys.executable, "-m", "actorswarm", "gs", *command, *gs],
                check=False, capture_output=True, text=True, timeout=60,
            )  # fmt: skip
            assert done.returncode == 0, done.stdout + done.stderr
        deadline = time.monotonic() + 40.0
        while time.monotonic() < deadline:
            if all(vehicle(p).get("armed") and vehicle(p).get("mode") == "TAKEOFF" for p in (1, 2)):
                break
            time.sleep(0.5)
        for p, altitude in ((1, 45.0), (2, 58.0)):  # its take-off layer: 45 + (p - 1) x 13
            seen = vehicle(p)
            assert seen.get("armed") and seen.get("airframe") == "plane", seen
            assert seen.get("mode") == "TAKEOFF", seen
            assert seen["failsafes"]["TKOFF_ALT"] == altitude, seen  # type: ignore[index]
        launcher.send_signal(signal.SIGINT)
        assert launcher.wait(timeout=40) == 0, "".join(out.lines)
    finally:
        if launcher.poll() is None:
            launcher.kill()
            launcher.wait()
