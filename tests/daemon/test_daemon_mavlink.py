"""``actorswarm daemon --vehicle mavlink``: its options refused clearly when wrong, and a real
daemon process flying the simulated MAVLink autopilot over UDP loopback — take-off by a
deployed script, the link and mode in status.json, the script's ``vehicle_link_lost``
transition when the autopilot falls silent."""

from __future__ import annotations

import math
import re
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.daemon.config import DaemonConfigError, load_daemon_config
from actorswarm.daemon.launch import LocalSwarm
from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
from actorswarm.vehicles.mavlink.frame import MissionFrame

runner = CliRunner()
ORIGIN = "47.397742,8.545594,488"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--vehicle", "mavlink", "--origin", ORIGIN], "give --mavlink URL"),
        (["--vehicle", "mavlink", "--mavlink", "udpin:127.0.0.1:0"], "give --origin LAT,LON"),
        (
            ["--vehicle", "mavlink", "--mavlink", "udpin:127.0.0.1:0", "--origin", "47,8"],
            "--origin '47,8': write it LAT,LON,ALT",
        ),
        (["--origin", ORIGIN], "need --vehicle mavlink"),
        (
            ["--vehicle", "mavlink", "--mavlink", "flight.tlog", "--origin", ORIGIN],
            "vehicle platform 1: cannot open MAVLink connection 'flight.tlog'",
        ),
        (["--vehicle", "boat"], "the vehicles are: none, sim, mavlink"),
    ],
)
def test_bad_mavlink_options_are_refused(args: list[str], message: str, tmp_path: Path) -> None:
    result = runner.invoke(
        app, ["daemon", "--platform", "1", "--insecure", "--state-dir", str(tmp_path), *args]
    )
    assert result.exit_code == 2, result.output
    assert message in result.output
    assert "Traceback" not in result.output


def test_a_bad_fence_in_the_configuration_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "d.toml"
    config.write_text(
        f'vehicle = "mavlink"\nmavlink = "udpin:127.0.0.1:0"\norigin = "{ORIGIN}"\n'
        "fence = [10, 0, -10, 5, 30]\n"
    )
    result = runner.invoke(app, ["daemon", "--platform", "1", "--config", str(config)])
    assert result.exit_code == 2 and "fence: an empty box" in result.output


def test_the_mavlink_keys_of_the_configuration_file(tmp_path: Path) -> None:
    config = tmp_path / "d.toml"
    config.write_text(
        'vehicle = "mavlink"\nmavlink = "/dev/ttyAMA0,921600"\nmavlink_sysid = 3\n'
        f'origin = "{ORIGIN}"\nmavlink_kind = "px4"\nmavlink_link_timeout = 2.5\n'
        "mavlink_force = false\nfence = [-300, -300, 300, 300, 60]\nmavlink_arm_timeout = 60\n"
    )
    parsed, _ = load_daemon_config(config)
    assert (parsed.vehicle, parsed.mavlink, parsed.mavlink_sysid) == (
        "mavlink",
        "/dev/ttyAMA0,921600",
        3,
    )
    assert parsed.mavlink_kind == "px4" and parsed.mavlink_link_timeout == 2.5
    assert parsed.fence == [-300, -300, 300, 300, 60] and parsed.mavlink_arm_timeout == 60
    for text, key in [
        ("mavlink_sysid = 300\n", "$.mavlink_sysid"),
        ('mavlink_kind = "inav"\n', "$.mavlink_kind"),
        ("fence = [1, 2]\n", "$.fence"),
        ("mavlink_link_timeout = 0\n", "$.mavlink_link_timeout"),
        ("mavlink_arm_timeout = -1\n", "$.mavlink_arm_timeout"),
    ]:
        config.write_text(text)
        with pytest.raises(DaemonConfigError, match=re.escape(key)):
            load_daemon_config(config)


@pytest.fixture
def autopilot() -> Iterator[tuple[SimAutopilot, threading.Event, int]]:
    from actorswarm.daemon.launch import free_ports

    port = free_ports(1)[0]
    home = MissionFrame(*MissionFrame(47.397742, 8.545594, 488.0).to_geodetic(15.0, 5.0, 0.0))
    sim = SimAutopilot(AutopilotOptions(f"udpin:127.0.0.1:{port}", home, system=3, ready_after=1.0))
    stop = threading.Event()
    thread = threading.Thread(target=sim.run, args=(stop,), daemon=True)
    thread.start()
    yield sim, stop, port
    stop.set()
    thread.join(timeout=2)
    sim.close()


def test_a_daemon_flies_the_autopilot_and_handles_a_lost_link(
    autopilot: tuple[SimAutopilot, threading.Event, int], tmp_path: Path
) -> None:
    sim, stop, port = autopilot
    with LocalSwarm(tmp_path, 1) as swarm:
        _start_one(swarm, f"udpout:127.0.0.1:{port}", sysid=3, timeout=20)
        status = swarm.status(1)
        assert status["vehicle"]["autopilot"] == "ardupilot"
        assert status["vehicle"]["system"] == 3
        assert swarm.events(1, "started")[0]["vehicle"] == "mavlink"
        _deploy_and_start(swarm, tmp_path, "lost.xml")
        swarm.wait(
            "up at 5 m and hovering",
            lambda: swarm.status(1).get("actors") == ["Hover"],
            timeout=30,
            detail=lambda: str(swarm.status(1).get("position")),
        )
        x, y, z = swarm.status(1)["position"]
        # The autopilot stands 15 m east and 5 m north of the mission origin.
        assert abs(x - 15.0) < 0.5 and abs(y - 5.0) < 0.5 and abs(z - 5.0) < 1.0
        assert sim.armed and sim.mode_name == "GUIDED"
        swarm.wait(
            "the mode in status.json", lambda: swarm.status(1)["vehicle"]["mode"] == "GUIDED"
        )
        # ... and the operator sees the link and the mode with `gs status`.
        shown = swarm.gs("status")
        assert shown.returncode == 0, shown.stderr
        assert "vehicle: link up, ardupilot GUIDED, armed" in shown.stdout, shown.stdout

        # The operator takes the vehicle, then gives it back.
        assert swarm.gs("event", "vehicle_hold").returncode == 0
        swarm.wait("the override", lambda: swarm.status(1)["vehicle"]["override"] == "hold")
        assert swarm.gs("event", "vehicle_resume").returncode == 0
        swarm.wait("the release", lambda: swarm.status(1)["vehicle"]["override"] is None)
        assert [e["name"] for e in swarm.events(1, "vehicle-override")] == [
            "vehicle_hold",
            "vehicle_resume",
        ]

        stop.set()  # the autopilot falls silent
        swarm.wait(
            "the script's vehicle_link_lost transition",
            lambda: swarm.status(1).get("actors") == ["Lost"],
            timeout=15,
        )
        last = swarm.status(1)["transitions"][-1]
        assert (last["from"], last["to"], last["event"]) == ("Hover", "Lost", "vehicle_link_lost")
        assert swarm.status(1)["vehicle"]["link"] == "lost"
        assert [e["name"] for e in swarm.events(1, "vehicle-event")] == ["vehicle_link_lost"]
        assert any("no HEARTBEAT from system 3" in e["error"]
                   for e in swarm.events(1, "vehicle-error"))  # fmt: skip


def test_two_daemons_fly_take_off_formation_return_and_land(tmp_path: Path) -> None:
    """examples/mavlink_two.xml on two real daemons, each flying its own simulated
    autopilot (one ArduPilot, one PX4) over UDP: up together, a line abreast to 20 m east
    and 10 m north, home and landed."""
    from actorswarm.daemon.launch import free_ports

    origin = MissionFrame(47.397742, 8.545594, 488.0)
    homes = {1: (-4.0, -6.0, 0.0), 2: (4.0, -6.0, 0.0)}
    ports = free_ports(2)
    sims: dict[int, SimAutopilot] = {}
    stop = threading.Event()
    threads = []
    for (platform, home), port, kind in zip(
        homes.items(), ports, ("ardupilot", "px4"), strict=True
    ):
        sims[platform] = SimAutopilot(
            AutopilotOptions(
                f"udpin:127.0.0.1:{port}", MissionFrame(*origin.to_geodetic(*home)),
                system=10 + platform, kind=kind,  # type: ignore[arg-type]
                ready_after=1.5,
            )
        )  # fmt: skip
        threads.append(threading.Thread(target=sims[platform].run, args=(stop,), daemon=True))
    for thread in threads:
        thread.start()
    try:
        with LocalSwarm(tmp_path, 2) as swarm:
            state, script = _start_linked(swarm, homes, ports, 10, tmp_path)
            deployed = swarm.gs("deploy", script, "--expect", "2", *state)
            assert deployed.returncode == 0, deployed.stdout + deployed.stderr
            assert swarm.gs("start", *state).returncode == 0
            swarm.wait(
                "both in formation",
                lambda: all(swarm.status(p).get("actors") == ["Formation"] for p in homes),
                timeout=40,
            )
            assert all(sim.position()[2] > 5.0 for sim in sims.values())
            swarm.wait(
                "both returning",
                lambda: all(swarm.status(p).get("actors") == ["Return"] for p in homes),
                timeout=60,
                detail=lambda: str([swarm.status(p).get("position") for p in homes]),
            )
            swarm.wait(
                "both landed at home, disarmed",
                lambda: all(
                    not sim.armed and sim.physics_mode == "landed" for sim in sims.values()
                ),
                timeout=60,
                detail=lambda: str({p: (s.position(), s.mode_name) for p, s in sims.items()}),
            )
            for platform, sim in sims.items():
                x, y, z = sim.position()  # metres from its own home
                assert math.hypot(x, y) < 3.0 and z == pytest.approx(0.0, abs=0.05), platform
                errors = swarm.events(platform, "vehicle-error")
                assert errors == [], errors
                # The formation's plugins and the slot assignment's solver were loaded off
                # the loop at deploy; loaded in the loop when the master released the
                # formation (SciPy: up to seconds), they silenced it past T_leave and the
                # member elected itself and released again with slots of its own.
                loaded = [e["loaded"] for e in swarm.events(platform, "prefetched")]
                assert loaded and "slot assignment" in loaded[-1], loaded
    finally:
        stop.set()
        for thread in threads:
            thread.join(timeout=2)
        for sim in sims.values():
            sim.close()


def test_sigterm_stops_a_daemon_whose_tcp_autopilot_vanished_within_a_second(
    tmp_path: Path,
) -> None:
    """The autopilot's TCP link goes away (a reboot); the daemon logs it as structured
    lines only, keeps retrying, and a SIGTERM stops it within 1 s, exit 0, no traceback."""
    import json
    import os
    import signal
    import socket
    import time

    os.environ.setdefault("MAVLINK20", "1")  # the test's own peer speaks MAVLink 2
    from pymavlink import mavutil

    from actorswarm.vehicles.mavlink.dialect import mav

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    peer = mavutil.mavlink_connection(
        f"tcpin:127.0.0.1:{port}", source_system=1, source_component=1
    )
    with LocalSwarm(tmp_path, 1) as swarm:
        proc = swarm.start(
            1, "--vehicle", "mavlink", "--mavlink", f"tcp:127.0.0.1:{port}",
            "--origin", ORIGIN,
        )  # fmt: skip

        def beat() -> bool:
            peer.recv_match(blocking=False)  # accepts the daemon
            peer.mav.heartbeat_send(
                mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 3
            )
            return swarm.status(1).get("vehicle", {}).get("link") == "up"

        swarm.wait("the autopilot heard over TCP", beat, timeout=20)
        peer.close()  # the autopilot reboots
        swarm.wait("the break logged", lambda: bool(swarm.events(1, "vehicle-link")), timeout=10)
        time.sleep(1.5)  # a reconnection attempt or two
        began = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=10)
        took = time.monotonic() - began
        swarm.procs.pop(1)
        assert code == 0
        print(f"SIGTERM took {took:.3f} s")
        assert took < 1.0, f"SIGTERM took {took:.2f} s"
        text = swarm.log(1).read_text()
        assert "Traceback" not in text
        for line in text.splitlines():
            json.loads(line)  # every line is a structured record
        assert swarm.events(1, "stopped")


def test_a_script_started_at_once_waits_for_a_booting_autopilot_and_says_why(
    tmp_path: Path,
) -> None:
    """End to end through a realistic boot, shortened to 15 s: ``actorswarm autopilot`` on
    TCP (its clock starts when the daemon connects), the script deployed and started at
    once. The take-off waits, ``gs status`` says for how long and the autopilot's words,
    then it flies."""
    import socket
    import subprocess
    import sys

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    pilot = subprocess.Popen(
        [sys.executable, "-m", "actorswarm", "autopilot", "--home", ORIGIN, "--sysid", "4",
         "--listen", f"tcpin:127.0.0.1:{port}", "--ready-after", "15"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        with LocalSwarm(tmp_path, 1) as swarm:
            _start_one(swarm, f"tcp:127.0.0.1:{port}", sysid=4, timeout=30)
            _deploy_and_start(swarm, tmp_path, "lost.xml")
            shown = ""

            def waiting() -> bool:
                nonlocal shown
                shown = swarm.gs("status").stdout
                return "not ready" in shown and "PreArm: " in shown

            swarm.wait("gs status: the take-off waiting, and why", waiting, timeout=20)
            pattern = r"vehicle: link up, ardupilot \w+, disarmed, .*not ready \d+ s — PreArm: "
            assert re.search(pattern, shown), shown
            swarm.wait("up at 5 m", lambda: swarm.status(1).get("actors") == ["Hover"], timeout=40)
            assert swarm.status(1)["vehicle"]["ready"] is True
            assert swarm.events(1, "vehicle-error") == []
            assert swarm.events(1, "vehicle-waiting") and swarm.events(1, "vehicle-ready")
    finally:
        pilot.terminate()
        pilot.wait(timeout=10)


def test_px4_flies_on_across_a_switch_between_two_moving_actors(tmp_path: Path) -> None:
    """Go (a goto that holds as it arrives) switches to Home (return home): PX4 must leave
    the outgoing actor's AUTO.LOITER for the incoming actor's OFFBOARD goal, and land at
    home, not hover where Go ended."""
    from actorswarm.daemon.launch import free_ports

    port = free_ports(1)[0]
    sim = SimAutopilot(
        AutopilotOptions(
            f"udpin:127.0.0.1:{port}", MissionFrame(47.397742, 8.545594, 488.0),
            system=5, kind="px4", ready_after=1.0,
        )
    )  # fmt: skip
    stop = threading.Event()
    thread = threading.Thread(target=sim.run, args=(stop,), daemon=True)
    thread.start()
    try:
        with LocalSwarm(tmp_path, 1) as swarm:
            _start_one(swarm, f"udpout:127.0.0.1:{port}", sysid=5, timeout=20)
            _deploy_and_start(swarm, tmp_path, "handover.xml")
            swarm.wait("Home", lambda: swarm.status(1).get("actors") == ["Home"], timeout=40)
            assert sim.position()[0] > 4.5  # Go got there
            swarm.wait(
                "landed at home, disarmed",
                lambda: not sim.armed and sim.physics_mode == "landed",
                timeout=30,
                detail=lambda: f"{sim.position()} {sim.mode_name}",
            )
            x, y, _ = sim.position()
            assert math.hypot(x, y) < 1.5
            assert swarm.events(1, "vehicle-error") == []
    finally:
        stop.set()
        thread.join(timeout=2)
        sim.close()


def test_one_of_two_that_cannot_take_off_is_grounded_and_the_other_flies_on(
    tmp_path: Path,
) -> None:
    """examples/mavlink_two.xml: platform 2's autopilot has its failsafes off, so its
    take-off fails for good; it raises vehicle_fault_event and switches to Grounded, which
    takes it out of the Standby group, and platform 1 flies the formation alone."""
    from actorswarm.daemon.launch import free_ports

    origin = MissionFrame(47.397742, 8.545594, 488.0)
    homes = {1: (-4.0, -6.0, 0.0), 2: (4.0, -6.0, 0.0)}
    ports = free_ports(2)
    sims: dict[int, SimAutopilot] = {}
    stop = threading.Event()
    threads = []
    for (platform, home), port in zip(homes.items(), ports, strict=True):
        sims[platform] = SimAutopilot(
            AutopilotOptions(
                f"udpin:127.0.0.1:{port}", MissionFrame(*origin.to_geodetic(*home)),
                system=20 + platform, ready_after=1.0, failsafes=platform == 1,
            )
        )  # fmt: skip
        threads.append(threading.Thread(target=sims[platform].run, args=(stop,), daemon=True))
    for thread in threads:
        thread.start()
    try:
        with LocalSwarm(tmp_path, 2) as swarm:
            state, script = _start_linked(swarm, homes, ports, 20, tmp_path)
            assert swarm.gs("deploy", script, "--expect", "2", *state).returncode == 0
            assert swarm.gs("start", *state).returncode == 0
            swarm.wait(
                "2 grounded, 1 in formation",
                lambda: (
                    swarm.status(2).get("actors") == ["Grounded"]
                    and swarm.status(1).get("actors") == ["Formation"]
                ),
                timeout=40,
            )
            fault = swarm.events(2, "vehicle-fault")
            assert len(fault) == 1 and "FS_GCS_ENABLE is 0" in fault[0]["reason"]
            last = swarm.status(2)["transitions"][-1]
            assert (last["from"], last["to"], last["event"]) == (
                "Standby",
                "Grounded",
                "vehicle_fault_event",
            )
            assert not sims[2].armed and sims[1].armed
    finally:
        stop.set()
        for thread in threads:
            thread.join(timeout=2)
        for sim in sims.values():
            sim.close()


def _start_linked(
    swarm: LocalSwarm,
    homes: dict[int, tuple[float, float, float]],
    ports: list[int],
    sysids: int,
    tmp_path: Path,
) -> tuple[list[str], str]:
    """Start one daemon per platform of ``homes`` on its autopilot's port (system ID
    ``sysids`` + platform), wait until both links are up and a master is agreed; returns the
    ground station's ``--state`` option and the two-copter script."""
    for platform, port in zip(homes, ports, strict=True):
        swarm.start(
            platform, "--vehicle", "mavlink", "--mavlink", f"udpout:127.0.0.1:{port}",
            "--mavlink-sysid", str(sysids + platform), "--origin", ORIGIN,
        )  # fmt: skip
    swarm.wait(
        "both links up and a master agreed",
        lambda: (
            swarm.agreed_master() is not None
            and all(swarm.status(p).get("vehicle", {}).get("link") == "up" for p in homes)
        ),
        timeout=30,
    )
    state = ["--state", str(tmp_path / "gs.json")]
    return state, str(Path(__file__).parents[2] / "examples" / "mavlink_two.xml")


def _start_one(swarm: LocalSwarm, link: str, *, sysid: int, timeout: float) -> None:
    """Start platform 1 on the autopilot at ``link`` (system ID ``sysid``) and wait until
    its daemon hears it."""
    swarm.start(
        1, "--vehicle", "mavlink", "--mavlink", link,
        "--mavlink-sysid", str(sysid), "--origin", ORIGIN,
    )  # fmt: skip
    swarm.wait(
        "the autopilot heard",
        lambda: swarm.status(1).get("vehicle", {}).get("link") == "up",
        timeout=timeout,
    )


def _deploy_and_start(swarm: LocalSwarm, tmp_path: Path, script: str) -> None:
    """Deploy the script ``script`` (next to this file) to the one platform and start it."""
    state = ["--state", str(tmp_path / "gs.json")]
    path = str(Path(__file__).with_name(script))
    deployed = swarm.gs("deploy", path, "--expect", "1", *state)
    assert deployed.returncode == 0, deployed.stdout + deployed.stderr
    assert swarm.gs("start", *state).returncode == 0
