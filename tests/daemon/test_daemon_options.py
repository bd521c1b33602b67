"""The daemon's options and configuration file: every mistake is refused with exit status 2
and a message naming it, before anything starts; a configuration file and
``--vehicle sim`` make a daemon that flies a simulated vehicle (real processes)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.daemon.config import DaemonConfigError, load_daemon_config
from actorswarm.daemon.launch import LocalSwarm

runner = CliRunner()


def _daemon(*args: str) -> tuple[int, str]:
    result = runner.invoke(app, ["daemon", *args])
    return result.exit_code, result.output


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("platfrm = 3\n", "unknown field `platfrm`"),
        ("platform = 0\n", "`int` >= 1 - at `$.platform`"),
        ('platform = "three"\n', "Expected `int | null`, got `str` - at `$.platform`"),
        ('vehicle = "boat"\n', "at `$.vehicle`"),
        ("listen = \n", "not TOML"),
        ("[core]\nt_leave = -1\n", "[core]: t_leave"),
        ("[core]\nheartbeat = 1\n", "[core]: "),
        ('broadcast = "radio"\n', "at `$.broadcast`"),
        ("lease = 0\n", "at `$.lease`"),
        ('platform = 1\nbroadcast = "multicast"\ngroup = "1.2.3.4:5"\n', "not a multicast"),
    ],
)
def test_a_bad_configuration_file_names_the_file_and_the_key(
    tmp_path: Path, text: str, message: str
) -> None:
    path = tmp_path / "daemon.toml"
    path.write_text(text)
    with pytest.raises(DaemonConfigError) as caught:
        load_daemon_config(path)
    assert str(caught.value).startswith(f"{path}: ")
    assert message in str(caught.value)
    code, output = _daemon("--config", str(path), "--insecure")
    assert code == 2 and message in output


def test_a_configuration_file_fills_what_the_command_line_leaves_out(tmp_path: Path) -> None:
    path = tmp_path / "robot" / "daemon.toml"
    path.parent.mkdir()
    path.write_text(
        'platform = 7\nswarm = "field"\nlisten = ["tcp/127.0.0.1:7999"]\nmulticast = false\n'
        'keys = "keys"\nstate_dir = "state"\nvehicle = "sim"\n[core]\nt_leave = 0.8\n'
    )
    parsed, core = load_daemon_config(path)
    assert parsed.platform == 7 and parsed.swarm == "field" and parsed.multicast is False
    assert parsed.path(parsed.keys, path.parent) == path.parent / "keys"
    assert core.t_leave == 0.8
    # The keys the file names do not exist: the daemon says so and how to make them.
    code, output = _daemon("--config", str(path))
    assert code == 2 and "keys init" in output and str(path.parent / "keys") in output


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((), "give --platform ID"),
        (("--platform", "1", "--transport", "udp"), "the transports are: zenoh"),
        (("--platform", "1", "--vehicle", "boat"), "the vehicles are: none, sim"),
        (("--platform", "1", "--world", "w.toml"), "give --vehicle sim too"),
        (("--platform", "1", "--vehicle", "sim", "--world", "nowhere.toml"), "no such file"),
        (("--platform", "1", "--swarm", "a/b"), "swarm name 'a/b'"),
        (("--platform", "1", "--config", "nowhere.toml"), "cannot read"),
        (("--platform", "1", "--fleet", "1-4"), "give --vehicle sim"),
        (("--platform", "1", "--vehicle", "sim", "--fleet", "4-1"), "--fleet '4-1': the range"),
        (("--platform", "9", "--vehicle", "sim", "--fleet", "1-4"), "platform 9 is not one of"),
        (("--platform", "1", "--broadcast", "radio"), "broadcast 'radio': say how broadcasts"),
        (
            ("--platform", "1", "--group", "224.0.0.9:7000", "--connect", "tcp/127.0.0.1:7"),
            "give --broadcast multicast (the mesh is chosen by --listen, --connect",
        ),
        (("--platform", "1", "--interface", "lo", "--relay"), "give --broadcast multicast"),
        (("--platform", "1", "--broadcast", "mesh", "--interface", "lo"), "give --broadcast"),
        (("--platform", "1", "--interface", "lo;x"), "interface 'lo;x'"),
        (
            ("--platform", "1", "--broadcast", "multicast", "--group", "10.1.1.1:7000"),
            "10.1.1.1 is not a multicast address",
        ),
        (
            ("--platform", "1", "--broadcast", "multicast", "--group", "224.0.0.9"),
            "write ADDRESS:PORT",
        ),
        (
            ("--platform", "1", "--broadcast", "multicast", "--interface", "wlan0;x"),
            "interface 'wlan0;x'",
        ),
        (
            ("--platform", "1", "--broadcast", "multicast", "--connect", "tcp/127.0.0.1:7447"),
            "no connect endpoints",
        ),
        (
            ("--platform", "1", "--broadcast", "multicast", "--multicast"),
            "no multicast scouting",
        ),
    ],
)
def test_bad_options_are_refused_before_anything_starts(
    tmp_path: Path, args: tuple[str, ...], message: str
) -> None:
    code, output = _daemon(*args, "--insecure", "--state-dir", str(tmp_path / "s"))
    assert code == 2, output
    assert message in output
    assert not (tmp_path / "s").exists()


def test_a_world_file_that_is_not_a_world_is_refused(tmp_path: Path) -> None:
    world = tmp_path / "w.toml"
    world.write_text("[fleet]\nkind = 'submarine'\n")
    code, output = _daemon("--platform", "1", "--vehicle", "sim", "--world", str(world))
    assert code == 2 and str(world) in output


@pytest.fixture
def swarm(tmp_path: Path) -> Iterator[LocalSwarm]:
    with LocalSwarm(tmp_path, 2) as s:
        yield s


def test_daemons_fly_simulated_vehicles_through_a_task(swarm: LocalSwarm, tmp_path: Path) -> None:
    """Platform 1 takes ``--vehicle sim`` from the command line, platform 2 from its
    configuration file; both take off to 8 m and hover together once both are up."""
    config = tmp_path / "two.toml"
    config.write_text('vehicle = "sim"\n[core]\nt_leave = 0.6\n')
    swarm.start(1, "--vehicle", "sim")
    swarm.start(2, "--config", str(config))
    swarm.wait("two daemons that agree on a master", lambda: swarm.agreed_master() is not None)
    assert swarm.events(2, "started")[0]["vehicle"] == "sim"
    state = ["--state", str(tmp_path / "gs.json")]
    deployed = swarm.gs("deploy", str(Path(__file__).with_name("fly.xml")), "--expect", "2", *state)
    assert deployed.returncode == 0, deployed.stdout + deployed.stderr
    assert swarm.gs("start", *state).returncode == 0
    swarm.wait(
        "both vehicles up and hovering",
        lambda: all(swarm.status(p).get("actors") == ["Hover"] for p in (1, 2)),
        timeout=40,
        detail=lambda: str([swarm.status(p).get("position") for p in (1, 2)]),
    )
    for p in (1, 2):
        z = swarm.status(p)["position"][2]
        assert abs(z - 8.0) <= 1.5, (p, z)


def test_the_fleet_may_come_from_the_configuration_file(tmp_path: Path) -> None:
    config = tmp_path / "robot.toml"
    config.write_text('platform = 9\nvehicle = "sim"\nfleet = "1-4"\n')
    code, output = _daemon("--config", str(config), "--insecure")
    assert code == 2 and "fleet: platform 9 is not one of the swarm's platforms" in output


def test_a_simulated_vehicle_starts_at_its_home_in_the_world_fleet(tmp_path: Path) -> None:
    """``--vehicle sim`` places platform 4 where the simulator places it in the world's
    fleet (slot 4 of a two-column grid), not at the grid's first home."""
    world = tmp_path / "w.toml"
    world.write_text('[fleet]\nplatforms = "1-4"\ncolumns = 2\nspacing = 30\norigin = [5, 5]\n')
    with LocalSwarm(tmp_path / "s", 4) as one:
        one.start(4, "--vehicle", "sim", "--world", str(world))
        one.wait("platform 4 to start", lambda: bool(one.events(4, "started")))
        assert one.events(4, "started")[0]["position"] == [35.0, 35.0, 0.0]


def test_a_daemon_listens_longer_than_the_simulator_before_it_claims_mastership() -> None:
    from actorswarm.core.config import CoreConfig
    from actorswarm.daemon.config import BOOT_WAIT, daemon_core

    assert daemon_core(CoreConfig()).startup_wait == BOOT_WAIT > CoreConfig().startup_wait
    assert daemon_core(CoreConfig(boot_wait=0.3)).startup_wait == 0.3
