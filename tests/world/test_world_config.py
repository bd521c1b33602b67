"""The world description: defaults, the shipped example, layouts, and errors that name keys."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import pytest

from actorswarm.world import (
    Area,
    FixedWingParams,
    FleetGroup,
    QuadrotorParams,
    RadioConfig,
    TargetConfig,
    VehicleEntry,
    WorldConfig,
    WorldError,
    load_world,
    loads_world,
    parse_platforms,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "worlds" / "default.toml"


def error_of(text: str) -> WorldError:
    with pytest.raises(WorldError) as info:
        loads_world(text, source="w.toml")
    return info.value


# --- defaults ------------------------------------------------------------------------------------


def test_defaults_are_the_documented_numbers() -> None:
    config = load_world(None)
    assert config == WorldConfig()
    assert config.world.step == 0.05
    q, f = config.quadrotor, config.fixed_wing
    assert (q.max_speed, q.max_accel, q.max_climb) == (12.0, 4.0, 3.0)
    # The fixed-wing is ArduPlane 4.5.7's (tests/world/test_fixedwing_conformance.py).
    assert (f.min_airspeed, f.max_speed, f.cruise_speed, f.max_turn_rate) == (10, 30, 22, 26)
    assert (f.max_climb, f.max_accel, f.loiter_radius, f.loiter_clockwise) == (4.8, 5.13, 50, True)
    assert q.endurance > 0 and f.endurance > 0
    assert config.targets == () and config.areas == ()
    assert loads_world("") == dataclasses.replace(WorldConfig(), source="<string>")


def test_defaults_for_platforms_place_a_square_grid() -> None:
    config = WorldConfig.defaults([4, 1, 3, 2], kind="fixed_wing")
    specs = config.vehicle_specs()
    assert [s.platform for s in specs] == [1, 2, 3, 4]
    assert {s.kind for s in specs} == {"fixed_wing"}
    assert all(isinstance(s.params, FixedWingParams) for s in specs)
    # Two columns for four platforms, 10 m apart, in ascending ID order.
    assert [s.home for s in specs] == [(0.0, 0.0), (10.0, 0.0), (0.0, 10.0), (10.0, 10.0)]
    assert all(s.heading == pytest.approx(math.pi / 2) and s.battery == 1.0 for s in specs)


def test_defaults_refuse_bad_platforms_and_kinds() -> None:
    with pytest.raises(WorldError, match="platform IDs are integers"):
        WorldConfig.defaults([0, 1])
    with pytest.raises(WorldError, match='did you mean "fixed_wing"'):
        WorldConfig.defaults([1], kind="fixed-wing")  # type: ignore[arg-type]


def test_a_world_without_platforms_needs_them_from_the_run() -> None:
    with pytest.raises(WorldError, match=r"fleet\.platforms"):
        WorldConfig().vehicle_specs()
    assert len(WorldConfig().vehicle_specs(range(1, 31))) == 30


# --- the shipped example -------------------------------------------------------------------------


def test_shipped_example_loads_with_the_default_physics() -> None:
    config = load_world(EXAMPLE)
    defaults = WorldConfig()
    for section in ("world", "fleet", "quadrotor", "fixed_wing", "radio"):
        assert getattr(config, section) == getattr(defaults, section), section
    assert config.source == str(EXAMPLE)
    assert [t.name for t in config.targets] == ["jeep"]
    search = config.area("search")
    assert search.contains(500.0, 0.0) and not search.contains(0.0, 0.0)


def test_shipped_example_documents_every_key() -> None:
    text = EXAMPLE.read_text(encoding="utf-8")
    sections: dict[str, type] = {
        "world": type(WorldConfig().world),
        "fleet": type(WorldConfig().fleet),
        "quadrotor": QuadrotorParams,
        "fixed_wing": FixedWingParams,
        "radio": RadioConfig,
    }
    for cls in sections.values():
        for field in dataclasses.fields(cls):
            name = field.name
            if name == "groups":
                assert "# [[fleet.groups]]" in text
                continue
            assert re.search(rf"^#? ?{name} = ", text, re.MULTILINE), f"{cls.__name__}.{name}"
    for cls in (FleetGroup, VehicleEntry, TargetConfig):
        for field in dataclasses.fields(cls):
            assert re.search(rf"^#? ?{field.name} = ", text, re.MULTILINE), field.name
    for key in ("rect", "polygon", "[[vehicles]]", "[[targets]]", "[[areas]]"):
        assert key in text, key


# --- a full file ---------------------------------------------------------------------------------


FULL = """
[world]
step = 0.1

[fleet]
kind = "fixed_wing"
platforms = "1-6"
origin = [100, -50]
spacing = 20
columns = 3
heading = 0
battery = 0.9

[[fleet.groups]]
platforms = [5, 6]
kind = "quadrotor"
battery = 0.5

[[vehicles]]
platform = 2
home = [-10.0, 7.5]
heading = 180

[[vehicles]]
platform = 6
kind = "fixed_wing"

[quadrotor]
max_speed = 10

[fixed_wing]
loiter_radius = 120

[[targets]]
name = "jeep"
route = [[0, 0], [100, 0, 2]]
speed = 4
loop = false
start = 5

[[areas]]
name = "triangle"
polygon = [[0, 0], [10, 0], [0, 10]]

[radio]
range = 500
"""


def test_a_full_file_resolves_every_platform() -> None:
    config = loads_world(FULL, source="full.toml")
    assert config.world.step == 0.1
    specs = {s.platform: s for s in config.vehicle_specs()}
    assert sorted(specs) == [1, 2, 3, 4, 5, 6]
    assert specs[1].kind == "fixed_wing" and specs[1].home == (100.0, -50.0)
    assert specs[1].heading == 0.0 and specs[1].battery == 0.9
    assert specs[2].home == (-10.0, 7.5) and specs[2].heading == pytest.approx(math.pi)
    assert specs[4].home == (100.0, -30.0)  # second row of three
    assert specs[5].kind == "quadrotor" and specs[5].battery == 0.5
    assert specs[5].params == QuadrotorParams(max_speed=10.0)
    assert specs[6].kind == "fixed_wing" and specs[6].battery == 0.5  # entry over group
    assert config.fixed_wing.loiter_radius == 120.0
    (jeep,) = config.targets
    assert jeep.route == ((0.0, 0.0, 0.0), (100.0, 0.0, 2.0)) and not jeep.loop
    assert config.area("triangle").area == pytest.approx(50.0)
    assert config.radio.range == 500.0


def test_a_run_may_name_other_platforms_than_the_file() -> None:
    config = loads_world(FULL)
    specs = config.vehicle_specs([5, 9])
    assert [(s.platform, s.kind) for s in specs] == [(5, "quadrotor"), (9, "fixed_wing")]


@pytest.mark.parametrize(
    ("text", "ids"),
    [("1-3, 7", (1, 2, 3, 7)), ("4", (4,)), ("2-2,1", (1, 2))],
)
def test_platform_ranges(text: str, ids: tuple[int, ...]) -> None:
    assert parse_platforms(text) == ids
    assert parse_platforms([3, 1, 3]) == (1, 3)
    assert parse_platforms(9) == (9,)


@pytest.mark.parametrize("text", ["3-1", "a-b", "0-4", "1-70000", "1,,2"])
def test_bad_platform_ranges(text: str) -> None:
    with pytest.raises(ValueError):
        parse_platforms(text)


def test_areas() -> None:
    square = Area.rect("a", 0, 0, 10, 20)
    assert square.bounds == (0.0, 0.0, 10.0, 20.0)
    assert square.centroid == pytest.approx((5.0, 10.0))
    assert square.area == 200.0
    assert square.contains(1, 19) and not square.contains(11, 5)
    with pytest.raises(WorldError, match="no area"):
        Area(name="line", polygon=((0, 0), (1, 1), (2, 2)))
    with pytest.raises(KeyError, match='did you mean "search"'):
        load_world(EXAMPLE).area("serch")


# --- errors name the file, the key path and the problem ------------------------------------------


@pytest.mark.parametrize(
    ("text", "key", "problem"),
    [
        ("[fleet]\nspacng = 3", "fleet.spacng", 'did you mean "spacing"'),
        ("[quadrotor]\nmax_sped = 3", "quadrotor.max_sped", 'did you mean "max_speed"'),
        ("[radoi]\nrange = 3", "radoi", 'did you mean "radio"'),
        (
            '[[targets]]\nname = "j"\nroute = [[0, 0]]\nspeed = 1\nlop = true',
            "targets[0].lop",
            'did you mean "loop"',
        ),
        (
            '[[fleet.groups]]\nplatforms = "1-2"\nkind = "fixed_wing"\nbatery = 1',
            "fleet.groups[0].batery",
            'did you mean "battery"',
        ),
    ],
)
def test_unknown_keys_get_suggestions(text: str, key: str, problem: str) -> None:
    err = error_of(text)
    assert err.source == "w.toml" and err.key == key
    assert "unknown key" in err.problem and problem in err.problem
    assert str(err).startswith(f"w.toml: {key}: ")


@pytest.mark.parametrize(
    ("text", "key", "problem"),
    [
        ('[world]\nstep = "fast"', "world.step", "must be a number"),
        ("[world]\nstep = 0", "world.step", "> 0"),
        ("[world]\nstep = true", "world.step", "must be a number"),
        ("[quadrotor]\ncruise_speed = 20", "quadrotor.cruise_speed", "above max_speed"),
        ("[fixed_wing]\nmin_airspeed = 31", "fixed_wing.min_airspeed", "above max_speed"),
        ("[fixed_wing]\nloiter_clockwise = 1", "fixed_wing.loiter_clockwise", "true or false"),
        ("[fixed_wing]\nglide_slope = 50", "fixed_wing.glide_slope", "below 45 degrees"),
        ("[fixed_wing]\nloiter_radius = 20", "fixed_wing.loiter_radius", "turn radius"),
        ("[fixed_wing]\nmax_climb = 15", "fixed_wing.max_climb", "below min_airspeed"),
        ('[fleet]\nkind = "quadrotors"', "fleet.kind", 'did you mean "quadrotor"'),
        ("[fleet]\norigin = [1]", "fleet.origin", "2 numbers"),
        ("[fleet]\ncolumns = 2.5", "fleet.columns", "integer"),
        ("[fleet]\nbattery = 1.5", "fleet.battery", "(0, 1]"),
        ('[fleet]\nplatforms = "5-1"', "fleet.platforms", "backwards"),
        (
            '[[fleet.groups]]\nplatforms = "1-3"\nkind = "quadrotor"\n'
            '[[fleet.groups]]\nplatforms = "3-4"\nkind = "fixed_wing"',
            "fleet.groups[1].platforms",
            "platform 3 is already in groups[0]",
        ),
        ('[[fleet.groups]]\nplatforms = "1"', "fleet.groups[0].kind", "required"),
        ("[[vehicles]]\nplatform = 1\n[[vehicles]]\nplatform = 1", "vehicles[1].platform", "entry"),
        ("[[vehicles]]\nplatform = 0", "vehicles[0].platform", "1..65535"),
        ("[[vehicles]]\nplatform = 2\nhome = [1, 2, 3]", "vehicles[0].home", "2 numbers"),
        ('[[targets]]\nname = "j"\nspeed = 1', "targets[0].route", "required"),
        (
            '[[targets]]\nname = "j"\nroute = [[0, 0], [1]]\nspeed = 1',
            "targets[0].route[1]",
            "2 or 3 numbers",
        ),
        ('[[targets]]\nname = "j"\nroute = []\nspeed = 1', "targets[0].route", "waypoint"),
        ('[[targets]]\nname = "j"\nroute = [[0, 0]]\nspeed = -1', "targets[0].speed", ">= 0"),
        (
            '[[areas]]\nname = "a"\nrect = [0, 0, 1, 1]\n'
            '[[areas]]\nname = "a"\nrect = [0, 0, 1, 1]',
            "areas[1].name",
            "already the name",
        ),
        ('[[areas]]\nname = "a"', "areas[0]", "exactly one of"),
        ('[[areas]]\nname = "a"\nrect = [1, 0, 0, 1]', "areas[0].rect", "min < max"),
        ("[radio]\nloss_at_range = 2", "radio.loss_at_range", "[0, 1]"),
        ("radio = 3", "radio", "must be a table"),
        ("vehicles = 3", "vehicles", "array of tables"),
    ],
)
def test_validation_errors_name_the_key_path(text: str, key: str, problem: str) -> None:
    err = error_of(text)
    assert (err.source, err.key) == ("w.toml", key), str(err)
    assert problem in err.problem, str(err)


def test_file_errors_name_the_file(tmp_path: Path) -> None:
    broken = tmp_path / "broken.toml"
    broken.write_text("[world\nstep = 1", encoding="utf-8")
    with pytest.raises(WorldError, match=r"broken\.toml: not valid TOML"):
        load_world(broken)
    with pytest.raises(WorldError, match=r"missing\.toml: cannot read"):
        load_world(tmp_path / "missing.toml")
    good = tmp_path / "good.toml"
    good.write_text("[fleet]\nspacing = 5\n", encoding="utf-8")
    assert load_world(good).fleet.spacing == 5.0
    good.write_text("[fleet]\nspacing = -5\n", encoding="utf-8")
    with pytest.raises(WorldError, match=r"good\.toml: fleet\.spacing: must be"):
        load_world(good)


def test_configs_built_in_code_are_checked_too() -> None:
    with pytest.raises(WorldError, match=r"^QuadrotorParams: max_accel: "):
        QuadrotorParams(max_accel=0)
    with pytest.raises(WorldError, match=r"^RadioConfig: range: "):
        RadioConfig(range=math.inf)


# --- one vehicle flown alone (a daemon's --vehicle sim) ----------------------------------------


def test_a_vehicle_flown_alone_starts_at_its_home_in_the_whole_fleet() -> None:
    """A daemon's world holds its own vehicle only; it starts where the simulator puts that
    platform among the fleet, whether the fleet comes from the file or from the caller."""
    from actorswarm.world.world import World

    listed = loads_world(
        '[fleet]\nplatforms = "1-6"\ncolumns = 3\nspacing = 25\norigin = [100, -50]\n'
        "[[vehicles]]\nplatform = 2\nhome = [7, 8]\nheading = 45\n",
        source="w.toml",
    )
    whole = World(listed, None).positions()
    for pid in (1, 2, 5, 6):
        alone = World(listed.alone(pid), [pid])
        assert alone.positions()[pid] == whole[pid], pid
        (spec,) = listed.alone(pid).vehicle_specs([pid])
        assert spec == listed.vehicle_specs()[pid - 1], pid  # kind, heading, battery too
    assert whole[6] == (150.0, -25.0, 0.0)  # slot 5: column 2 of row 1
    unlisted = WorldConfig()  # the default grid: columns follow the swarm's size
    fleet = range(1, 11)
    whole = World(unlisted, list(fleet)).positions()
    assert World(unlisted.alone(10, fleet), [10]).positions()[10] == whole[10] != whole[1]
    # No fleet anywhere: the platform alone, at the grid's first home.
    assert World(unlisted.alone(10), [10]).positions()[10] == whole[1]


def test_a_fleet_without_the_platform_is_refused() -> None:
    listed = loads_world('[fleet]\nplatforms = "1-6"\n', source="w.toml")
    with pytest.raises(WorldError, match=r"w\.toml: fleet\.platforms: platform 9 is not"):
        listed.alone(9)
    with pytest.raises(WorldError, match=r"fleet: platform 9 is not one of"):
        listed.alone(9, [1, 2])
