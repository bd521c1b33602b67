"""Before flight: ``task check --world`` warns about an actor that takes off and does not
answer an autopilot that never lets it (``vehicle_fault_event``)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.dsl import check
from actorswarm.runtime.context import VEHICLE_FAULT_EVENT as FAULT_EVENT
from actorswarm.world.config import loads_world

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """<TaskScript name="up" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Standby</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.takeoff</_P_Name><param key="altitude" value="20"/></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Home</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.return_home</_P_Name></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Grounded</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>core.idle</_P_Name></Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Standby">
      <transition name="ready_event" barrierKey="1" sysNum="all" timeout="60" timeoutBranch="Home">
        <successor actor="Home"/>
      </transition>
      ANSWER
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-3" actor="Standby"/></_PlatformActorConfig>
</TaskScript>
"""

ANSWER = (
    '<transition name="vehicle_fault_event" barrierKey="2" sysNum="1">'
    '<successor actor="Grounded"/></transition>'
)


def _faults(script: str, world: str | None = "") -> list[tuple[int, int, str]]:
    result = check(script, path="s.xml", world=None if world is None else loads_world(world))
    assert result.ok, [str(d) for d in result.errors]
    return [(d.line, d.col, d.message) for d in result.warnings if FAULT_EVENT in d.message]


def test_a_take_off_that_does_not_answer_the_fault_is_warned_about_at_its_plugin() -> None:
    ((line, col, message),) = _faults(SCRIPT.replace("ANSWER", ""))
    assert (line, col) == (4, 24), message  # the take-off plugin's name
    assert "stays in Standby for good" in message
    assert 'add <transition name="vehicle_fault_event" sysNum="1">' in message


def test_a_script_that_answers_it_or_has_no_vehicles_is_not() -> None:
    assert _faults(SCRIPT.replace("ANSWER", ANSWER)) == []
    assert _faults(SCRIPT.replace("ANSWER", ""), world=None) == []  # no world: no vehicles


def test_every_shipped_example_that_takes_off_answers_it() -> None:
    runner = CliRunner()
    checked = 0
    for script in sorted((ROOT / "examples").glob("*.xml")):
        text = script.read_text()
        if "flight.takeoff" not in text:
            continue
        world = text.split("--world ", 1)[1].split()[0]
        result = runner.invoke(app, ["task", "check", str(script), "--world", str(ROOT / world)])
        assert result.exit_code == 0, result.output
        assert FAULT_EVENT not in result.output, result.output
        checked += 1
    assert checked >= 5
