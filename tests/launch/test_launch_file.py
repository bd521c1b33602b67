"""The launch file: every mistake is refused with the file, the key and the line, before
anything starts; a good file gives each daemon the options it says."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.launch import LaunchError, load_launch

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "launch" / "branch-merge.toml"


def _load(tmp_path: Path, text: str) -> LaunchError:
    path = tmp_path / "swarm.toml"
    path.write_text(text)
    with pytest.raises(LaunchError) as caught:
        load_launch(path)
    return caught.value


@pytest.mark.parametrize(
    ("text", "where", "message"),
    [
        ('platforms = "1-3"\nswarm = \n', ":2", "not TOML"),
        ('platforms = "1-3"\n\nplatfroms = 4\n', ":3: platfroms: unknown key 'platfroms'", ""),
        ('swarm = "x"\n', ": platforms: missing", ""),
        ('platforms = "3-1"\n', ":1: platforms: ", "low to high"),
        ('platforms = "1-3"\nvehicle = "boat"\n', ":2: vehicle: 'boat'", "none, sim"),
        ('platforms = "1-3"\nports = [7501, 7502]\n', ":2: ports: 2 ports for 3", ""),
        ('platforms = "1-3"\nmulticast = true\nports = 7501\n', ":3: ports: ", "multicast"),
        ('platforms = "1-3"\nswarm = "a b"\n', ":2: swarm: ", "a b"),
        ('platforms = "1-3"\nkeys = "k"\ninsecure = true\n', ":3: insecure: ", "exclude"),
        ('platforms = "1-3"\ninsecure = "yes"\n', ":2: insecure: expected true or false", ""),
        ('platforms = "1-3"\n[platform.4]\nvehicle = "sim"\n', ": platform: [platform.4]", "[4]"),
        (
            'platforms = "1-3"\n[platform.2]\nvehicel = "sim"\n',
            ":3: vehicel: unknown key [platform.2] 'vehicel'",
            'did you mean "vehicle"',
        ),
        ('platforms = "1-3"\n[platform.2]\nworld = "none.toml"\n', ":3: platform.2.world: ", ""),
        ('platforms = "1-3"\nworld = "w.toml"\n', ":2: world: ", "no such file"),
    ],
)
def test_a_bad_launch_file_names_the_file_the_key_and_the_line(
    tmp_path: Path, text: str, where: str, message: str
) -> None:
    error = str(_load(tmp_path, text))
    assert error.startswith(f"{tmp_path / 'swarm.toml'}{where}"), error
    assert message in error


def test_the_command_refuses_a_bad_file_with_exit_2_and_starts_nothing(tmp_path: Path) -> None:
    path = tmp_path / "swarm.toml"
    path.write_text('platforms = "1-3"\nplatfroms = 4\ndirectory = "run"\n')
    result = CliRunner().invoke(app, ["launch", str(path)])
    assert result.exit_code == 2
    assert "unknown key 'platfroms'" in result.output
    assert 'did you mean "platforms"' in result.output
    assert not (tmp_path / "run").exists()


def test_overrides_and_defaults_make_each_daemon_command(tmp_path: Path) -> None:
    world = tmp_path / "w.toml"
    world.write_text("[fleet]\ncolumns = 2\n")
    path = tmp_path / "swarm.toml"
    path.write_text(
        'swarm = "s1"\nplatforms = "1-4"\ninsecure = true\nports = 7601\ndirectory = "run"\n'
        'vehicle = "sim"\nworld = "w.toml"\n[platform."3-4"]\nvehicle = "none"\n'
        '[platform.2]\nstate_dir = "/tmp/two"\n'
    )
    result = CliRunner().invoke(app, ["launch", str(path), "--check"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert len(lines) == 4
    assert not (tmp_path / "run").exists(), "--check starts nothing and writes nothing"
    one, two, three, four = lines
    assert f"--platform 1 --swarm s1 --insecure --state-dir {tmp_path / 'run' / 'state-1'}" in one
    assert f"--vehicle sim --fleet 1,2,3,4 --world {world}" in one
    assert "--listen tcp/127.0.0.1:7601" in one and "--connect" not in one
    assert "--state-dir /tmp/two" in two and "--connect tcp/127.0.0.1:7601" in two
    assert "--vehicle" not in three + four
    assert four.endswith(
        "--listen tcp/127.0.0.1:7604 --connect tcp/127.0.0.1:7601 "
        "--connect tcp/127.0.0.1:7602 --connect tcp/127.0.0.1:7603"
    )


def test_the_web_page_gets_the_world_the_simulated_vehicles_share(tmp_path: Path) -> None:
    for name in ("w.toml", "v.toml"):
        (tmp_path / name).write_text("[fleet]\ncolumns = 2\n")
    head = 'swarm = "s1"\nplatforms = "1-4"\ninsecure = true\n'

    def world(text: str) -> Path | None:
        path = tmp_path / "swarm.toml"
        path.write_text(head + text)
        return load_launch(path).shared_world()

    shared = 'vehicle = "sim"\nworld = "w.toml"\n[platform."3-4"]\nvehicle = "none"\n'
    assert world(shared) == tmp_path / "w.toml"
    from rich.console import Console

    from actorswarm.launch.runner import Launcher

    path = tmp_path / "web.toml"
    path.write_text(head + "ports = 7601\nweb = 7700\n" + shared)
    command = Launcher(load_launch(path), None, Console()).web_command()
    assert command[command.index("--world") + 1] == str(tmp_path / "w.toml")
    assert not (tmp_path / "run").exists(), "a launcher starts nothing until it runs"
    assert world('vehicle = "sim"\nworld = "w.toml"\n[platform.4]\nworld = "v.toml"\n') is None
    assert world('vehicle = "sim"\n') is None  # the default world: no file to name
    assert world("") is None  # no simulated vehicle


def test_the_shipped_example_starts_ten_platforms_of_the_branch_and_merge_swarm() -> None:
    plan = load_launch(EXAMPLE)
    assert plan.platforms == list(range(1, 11)) and plan.swarm == "branch-merge"
    assert plan.ports == tuple(range(7501, 7511)) and not plan.multicast
