"""The world: fixed steps in the caller's time, vehicles, targets, areas, radio, recording."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from actorswarm.world import MODES, World, WorldConfig, load_world, loads_world

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "worlds" / "default.toml"


def test_step_to_advances_in_whole_steps() -> None:
    world = World(WorldConfig.defaults([1, 2]))
    assert world.time == 0.0 and world.step == 0.05
    world.vehicle(1).takeoff(10)
    world.step_to(0.12)
    assert world.time == pytest.approx(0.10)
    world.step_to(0.3)  # 0.3 / 0.05 is 5.999..., still six steps
    assert world.time == pytest.approx(0.3)
    world.step_to(0.3)
    assert world.time == pytest.approx(0.3)
    with pytest.raises(ValueError, match="time runs forward"):
        world.step_to(0.2)
    with pytest.raises(ValueError, match="finite"):
        world.step_to(float("nan"))


def test_how_often_step_to_is_called_changes_nothing() -> None:
    def run(times: list[float]) -> dict[int, tuple[float, float, float]]:
        world = World(WorldConfig.defaults(range(1, 5), kind="fixed_wing"))
        for pid in world.platforms:
            world.vehicle(pid).goto(200.0 * pid, 100.0, 40.0)
        for t in times:
            world.step_to(t)
        return world.positions()

    assert run([60.0]) == run([i * 0.37 for i in range(163)] + [60.0])


def test_vehicles_targets_and_areas_from_the_example() -> None:
    world = World(load_world(EXAMPLE), [1, 2, 3])
    assert world.platforms == (1, 2, 3)
    assert world.positions() == {1: (0.0, 0.0, 0.0), 2: (10.0, 0.0, 0.0), 3: (0.0, 10.0, 0.0)}
    assert world.target_positions() == {"jeep": (400.0, -200.0, 0.0)}
    world.step_to(20.0)
    assert world.target_positions()["jeep"] == pytest.approx((500, -200, 0))
    assert world.targets["jeep"].position(world.time) == world.target_positions()["jeep"]
    assert set(world.areas) == {"search"}
    assert world.area("search").contains(*world.target_positions()["jeep"][:2])
    with pytest.raises(KeyError, match="platforms 1-3"):
        world.vehicle(4)


def test_the_world_can_name_its_own_platforms() -> None:
    world = World(loads_world('[fleet]\nplatforms = "3-5"'))
    assert world.platforms == (3, 4, 5)


def test_radio_links_follow_the_vehicles() -> None:
    config = loads_world(
        "[radio]\nrange = 300\nloss_at_range = 0.5\nloss_exponent = 1\n"
        "[[vehicles]]\nplatform = 2\nhome = [150, 0]\n"
        "[[vehicles]]\nplatform = 3\nhome = [1000, 0]\n"
    )
    world = World(config, [1, 2, 3])
    loss, latency = world.link(1, 2)
    assert loss == pytest.approx(0.25)
    assert latency == pytest.approx(0.005 + 0.001 * 0.15)
    assert world.link(1, 3)[0] == 1.0
    assert world.reachable().tolist() == [
        [True, True, False],
        [True, True, False],
        [False] * 2 + [True],
    ]
    matrix, _ = world.link_matrix()
    assert matrix[0, 1] == pytest.approx(0.25)
    world.vehicle(3).goto(200, 0, 20)  # takes off and flies into range
    world.step_to(120.0)
    assert world.link(1, 3)[0] < 1.0
    assert world.reachable().all()


def test_recording_for_pictures() -> None:
    world = World(load_world(EXAMPLE), [1, 2], record_every=1.0)
    world.vehicle(1).takeoff(5)
    world.step_to(10.0)
    world.record()  # an extra snapshot, by hand
    track = world.track()
    assert len(track) == 12
    assert track.times.tolist() == pytest.approx([*range(11), 10.0])
    assert track.positions.shape == (12, 2, 3)
    assert track.headings.shape == track.modes.shape == track.batteries.shape == (12, 2)
    assert track.target_names == ("jeep",)
    assert track.target_positions[5, 0] == pytest.approx((425, -200, 0))
    assert track.of(1)[-1, 2] == pytest.approx(5, abs=0.06)
    assert MODES[track.modes[0, 0]] == "ground" and MODES[track.modes[-1, 0]] == "flying"
    rows = list(track.rows())
    assert len(rows) == 24
    t, platform, x, y, z, heading, mode = rows[-2]
    assert (t, platform, mode) == (10.0, 1, "flying")
    assert (x, y, z) == pytest.approx((0, 0, 5), abs=0.06)
    assert heading == pytest.approx(np.pi / 2)
    assert rows[-1][1:5] == (2, 10.0, 0.0, 0.0)
    # Snapshots are copies, not views of the live state.
    assert not np.shares_memory(track.positions, world.fleet.positions)


def test_no_recording_unless_asked() -> None:
    world = World(WorldConfig.defaults([1]))
    world.step_to(5.0)
    track = world.track()
    assert len(track) == 0 and track.positions.shape == (0, 1, 3)
    with pytest.raises(ValueError, match="record_every"):
        World(WorldConfig.defaults([1]), record_every=0)


def test_public_names_exist_and_the_world_reads_no_clock() -> None:
    import ast
    import importlib

    package = importlib.import_module("actorswarm.world")
    assert not [name for name in package.__all__ if not hasattr(package, name)]
    folder = Path(package.__file__ or "").parent
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [alias.name.split(".")[0] for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module.split(".")[0]]
            else:
                continue
            assert not {"time", "datetime", "random"} & set(names), f"{path.name}: {names}"
