"""Separation in a simulated run: a breach is a violation in the report and the summary,
and with ``--min-separation`` (or the world's ``fatal_separation``) it stops the run."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from actorswarm.cli.app import app

# Two quadrotors take off and fly to one point: they meet there.
SCRIPT = """<TaskScript name="meet" version="1">
  <_ActorsConfig>
    <Actor><_P_Name>Go</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>flight.goto</_P_Name><param key="target" value="30 30 10"/></Plugin>
    </Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig/>
  <_PlatformActorConfig><platform id="1-2" actor="Go"/></_PlatformActorConfig>
</TaskScript>
"""


def _sim(tmp_path: Path, *extra: str, world: str = "") -> tuple[int, str, dict[str, object]]:
    script = tmp_path / "meet.xml"
    script.write_text(SCRIPT)
    args = ["sim", str(script), "--duration", "30", "--json", str(tmp_path / "r.json")]
    if world:
        (tmp_path / "w.toml").write_text(world)
        args += ["--world", str(tmp_path / "w.toml")]
    result = CliRunner().invoke(app, [*args, *extra])
    report = json.loads((tmp_path / "r.json").read_text())
    return result.exit_code, result.output, report


def test_a_breach_is_reported_and_fails_the_run(tmp_path: Path) -> None:
    code, output, report = _sim(tmp_path)
    assert code == 1, output
    separation = report["separation"]
    assert separation["breaches"] and separation["min_distance_m"] < 3.0
    assert separation["minimums_m"] == {"quadrotor": 3.0, "fixed_wing": 10.0}
    assert report["violations"][0].startswith("separation breach: platforms 1 and 2")
    assert report["halted"] is None and report["sim_time_s"] == 30.0
    assert "BREACH" in output and "1 separation breach(es)" in output
    assert "invariant(s)" not in output  # the protocol's invariants all held


def test_min_separation_stops_the_run_at_the_first_breach(tmp_path: Path) -> None:
    code, output, report = _sim(tmp_path, "--min-separation", "5")
    assert code == 1, output
    assert report["separation"]["minimums_m"] == {"quadrotor": 5.0, "fixed_wing": 10.0}
    halted = report["halted"]
    assert isinstance(halted, str) and "under the 5 m minimum" in halted
    assert report["completed"] is False and float(report["sim_time_s"]) < 30.0
    assert "the run stopped at the first" in output


def test_the_world_can_make_a_breach_fatal(tmp_path: Path) -> None:
    code, output, report = _sim(tmp_path, world="[safety]\nfatal_separation = true\n")
    assert code == 1, output
    assert report["halted"] is not None and float(report["sim_time_s"]) < 30.0


def test_min_separation_without_a_world_is_refused(tmp_path: Path) -> None:
    script = tmp_path / "meet.xml"
    script.write_text(
        SCRIPT.replace("flight.goto", "core.idle").replace(
            '<param key="target" value="30 30 10"/>', ""
        )
    )
    result = CliRunner().invoke(app, ["sim", str(script), "--no-world", "--min-separation", "5"])
    assert result.exit_code == 2
    assert "--min-separation needs vehicles: leave out --no-world" in result.output
