"""Before flight: the safety warnings of ``task check --world``, at the script's lines."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.dsl import check
from actorswarm.runtime.context import VEHICLE_FAULT_EVENT as FAULT_EVENT
from actorswarm.world.config import loads_world

SCRIPT = """<TaskScript name="s" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Up</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.takeoff</_P_Name><param key="altitude" value="150"/></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Arrow</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>formation.arrow</_P_Name>
        <param key="spacing" value="6"/>
        <param key="size" value="4"/>
      </Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Go</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.goto</_P_Name></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Look</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>search.area</_P_Name><param key="area" value="yard"/></Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Up">
      <transition name="a" sysNum="all"><successor actor="Arrow"/></transition>
    </actor>
    <actor name="Arrow">
      <transition name="g" sysNum="all">
        <param key="TargetPoint" value="100 100 130"/>
        <successor actor="Go"/>
      </transition>
    </actor>
    <actor name="Go">
      <transition name="l" sysNum="all"><successor actor="Look"/></transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-6" actor="Up"/></_PlatformActorConfig>
</TaskScript>
"""

WORLD = """
[fleet]
kind = "fixed_wing"
[safety]
ceiling = 120.0
[[areas]]
name = "yard"
rect = [0.0, 0.0, 20.0, 20.0]
"""


def _warnings(script: str, world: str) -> list[tuple[int, str]]:
    """The warnings of ``script`` in ``world`` but the take-off's unanswered fault, which
    tests/dsl/test_dsl_takeoff.py tests (these scripts take off and do not answer it)."""
    result = check(script, path="s.xml", world=loads_world(world))
    assert result.ok, [str(d) for d in result.errors]
    return [(d.line, d.message) for d in result.warnings if FAULT_EVENT not in d.message]


def test_each_warning_is_at_its_line() -> None:
    # What fixed-wings cannot fly is tests/dsl/test_dsl_fixedwing.py's.
    found = [w for w in _warnings(SCRIPT, WORLD) if "fixed-wing" not in w[1]]
    lines = {line for line, _ in found}
    text = " | ".join(message for _, message in found)
    assert len(found) == 6, text
    assert lines == {4, 8, 9, 13, 16, 25}, found
    by_line = dict(found)
    assert "altitude 150 m is above the world's ceiling of 120 m" in by_line[4]
    assert "spacing 6 m is below the vehicles' separation (fixed_wing 10 m" in by_line[8]
    assert "size 4 gives 4 slots but up to 6 platforms" in by_line[9]
    assert "up to 6 platforms may be sent here with no spacing" in by_line[13]
    assert "area 'yard' (400 m²) is too small for the 6 platforms" in by_line[16]
    assert "TargetPoint is at 130 m, above the world's ceiling of 120 m" in by_line[25]


def test_a_safe_script_in_its_world_has_no_warning() -> None:
    safe = (
        SCRIPT.replace('value="150"', 'value="60"')
        .replace('value="6"/>', 'value="40"/>')
        .replace('<param key="size" value="4"/>', "")
        .replace(
            "<_P_Name>flight.goto</_P_Name>",
            '<_P_Name>flight.goto</_P_Name><param key="spacing" value="12"/>',
        )
        .replace("100 100 130", "100 100 90")
    )
    world = WORLD.replace("20.0, 20.0]", "500.0, 500.0]")
    # (what fixed-wings cannot fly, the carrot and the tolerance: test_dsl_fixedwing.py's)
    assert [w for w in _warnings(safe, world) if "fixed-wing" not in w[1]] == []
    # Quadrotors keep 3 m: a spacing of 6 m is then enough.
    quads = SCRIPT.replace('value="150"', 'value="60"')
    assert not any("spacing 6 m" in m for _, m in _warnings(quads, "[safety]\nceiling = 0\n"))


def test_task_check_with_a_world_prints_them(tmp_path: Path) -> None:
    (tmp_path / "s.xml").write_text(SCRIPT)
    (tmp_path / "w.toml").write_text(WORLD)
    runner = CliRunner()
    result = runner.invoke(
        app, ["task", "check", str(tmp_path / "s.xml"), "--world", str(tmp_path / "w.toml")]
    )
    assert result.exit_code == 0, result.output
    assert f"{tmp_path / 's.xml'}:8:" in result.output
    assert "warning: formation.arrow: spacing 6 m" in result.output


def test_platforms_that_start_at_one_target_are_warned_about() -> None:
    script = """<TaskScript name="meet" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Go</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.goto</_P_Name><param key="target" value="30 30 10"/></Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig/>
  <_PlatformActorConfig><platform id="1-2" actor="Go"/></_PlatformActorConfig>
</TaskScript>
"""
    ((line, message),) = _warnings(script, "")
    assert line == 4
    assert message.startswith("flight.goto: the 2 platforms that start here all fly to this")
    assert "(quadrotor 3 m in the world)" in message


class _Sent(Exception):
    """The deployment reached the point of sending (the link is not opened in tests)."""


def test_gs_deploy_with_a_world_warns_and_still_sends(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from actorswarm.cli.swarm_options import Link

    def session(self: Link, patience: float | None = None) -> object:
        raise _Sent

    monkeypatch.setattr(Link, "session", session)
    (tmp_path / "s.xml").write_text(SCRIPT)
    (tmp_path / "w.toml").write_text(WORLD)
    args = ["gs", "deploy", "--expect", "6", "--insecure", "--state", str(tmp_path / "st.json")]
    result = CliRunner().invoke(
        app, [*args, "--world", str(tmp_path / "w.toml"), str(tmp_path / "s.xml")]
    )
    assert isinstance(result.exception, _Sent), result.output
    assert "warning: formation.arrow: spacing 6 m is below" in result.output


HOME = """<TaskScript name="h" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Home</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.return_home</_P_Name>
        <param key="altitude" value="60"/>
        <param key="layer_step" value="11"/>
        <param key="layers" value="LAYERS"/>
      </Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_PlatformActorConfig><platform id="1-30" actor="Home"/></_PlatformActorConfig>
</TaskScript>
"""


def test_the_layers_of_the_way_home_are_checked_against_the_ceiling() -> None:
    """30 platforms, one layer each from 60 m 11 m apart: the top is 379 m; six shared
    layers top out at 115 m, under the ceiling."""
    world = "[safety]\nceiling = 120.0\n"
    found = _warnings(HOME.replace("LAYERS", "0"), world)
    assert len(found) == 1, found
    line, message = found[0]
    assert line == 6
    assert "top layer of the way home is at 379 m (altitude 60 + 29 × layer_step 11)" in message
    assert _warnings(HOME.replace("LAYERS", "6"), world) == []


TRANSIT = """<TaskScript name="t" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>formation.arrow</_P_Name>
        <param key="altitude" value="100"/><param key="spacing" value="40"/>
        <param key="transit_step" value="14"/>
        <param key="transit_layers" value="LAYERS"/>
      </Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_PlatformActorConfig><platform id="1-30" actor="A"/></_PlatformActorConfig>
</TaskScript>
"""


def test_transit_layers_under_the_ground_or_over_the_ceiling_are_warned_about() -> None:
    """Thirty members, a transit layer each, 14 m apart around 100 m: fifteen below (the
    lowest at -110 m) and fifteen above (310 m); ten shared layers span 30..170 m."""
    world = "[safety]\nceiling = 200.0\n"
    found = _warnings(TRANSIT.replace("LAYERS", "0"), world)
    assert [line for line, _ in found] == [7, 7], found
    low, high = (message for _, message in found)
    assert "lowest transit layer is at -110 m, on or under the ground (30 transit layers" in low
    assert "highest transit layer is at 310 m" in high and "ceiling of 200 m" in high
    assert _warnings(TRANSIT.replace("LAYERS", "10"), world) == []
    # Without a ceiling only the ground counts.
    assert len(_warnings(TRANSIT.replace("LAYERS", "0"), "")) == 1
