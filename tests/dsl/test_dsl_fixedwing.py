"""Before flight: what fixed-wings cannot fly, warned by ``task check --world`` at the
script's lines — and nothing for the shipped fixed-wing missions in their worlds."""

from __future__ import annotations

from pathlib import Path

from actorswarm.dsl import check
from actorswarm.world.config import load_world, loads_world

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """<TaskScript name="s" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Arrow</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>formation.arrow</_P_Name>
        <param key="speed" value="8"/>
        <param key="lookahead" value="4"/>
        <param key="spacing" value="40"/>
      </Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Go</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.goto</_P_Name><param key="target" value="100 0 50"/>
        <param key="speed" value="40"/><param key="tolerance" value="10"/></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Home</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.return_home</_P_Name><param key="tolerance" value="50"/></Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Arrow">
      <transition name="g" sysNum="1"><successor actor="Go"/></transition>
    </actor>
    <actor name="Go">
      <transition name="h" sysNum="1"><successor actor="Home"/></transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1" actor="Arrow"/></_PlatformActorConfig>
</TaskScript>
"""

PLANES = '[fleet]\nkind = "fixed_wing"\n[fixed_wing]\nloiter_radius = 60.0\n'


def _warnings(script: str, world: str) -> list[tuple[int, str]]:
    result = check(script, path="s.xml", world=loads_world(world))
    assert result.ok, [str(d) for d in result.errors]
    return [(d.line, d.message) for d in result.warnings]


def test_each_impossible_request_is_warned_at_its_line() -> None:
    found = _warnings(SCRIPT, PLANES)
    by_line: dict[int, list[str]] = {}
    for line, message in found:
        by_line.setdefault(line, []).append(message)
    assert sorted(by_line) == [5, 6, 12, 15], found  # speed and tolerance share line 12
    assert "speed 8 m/s is below the fixed-wings' min_airspeed (10 m/s" in by_line[5][0]
    assert "the carrot is 32 m ahead of each slot" in by_line[6][0]
    assert "make lookahead at least 22.5" in by_line[6][0]
    goto = " | ".join(by_line[12])
    assert "flight.goto: speed 40 m/s is above the fixed-wings' max_speed (30 m/s" in goto
    assert "flight.goto: tolerance 10 m is below the fixed-wings' loiter radius (60 m" in goto
    assert (
        "flight.return_home: tolerance 50 m is below the fixed-wings' loiter radius (60 m"
        in (by_line[15][0])
    )


def test_quadrotors_are_not_held_to_a_fixed_wings_limits() -> None:
    assert not any("fixed-wing" in m for _, m in _warnings(SCRIPT, '[fleet]\nkind = "quadrotor"\n'))


def test_the_shipped_fixed_wing_missions_ask_nothing_impossible() -> None:
    missions = ROOT / "src" / "actorswarm" / "missions"
    world = load_world(missions / "formation_30.toml")
    for script in (
        missions / "formation_30.xml",
        ROOT / "examples" / "formation_arduplane.xml",
        ROOT / "examples" / "formation_arduplane_30.xml",
    ):
        result = check(script.read_text(), path=str(script), world=world)
        assert result.ok, [str(d) for d in result.errors]
        assert not [str(d) for d in result.warnings if "fixed-wing" in d.message]
