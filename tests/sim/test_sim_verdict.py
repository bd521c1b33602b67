"""``actorswarm sim`` says when a run went wrong: a schedule the script cannot use is refused
before the run, and a run with a failed plugin, a violated invariant or (with
``--expect-complete``) an unfinished task exits non-zero, saying why."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.sim.verdict import (
    EXIT_INCOMPLETE,
    EXIT_OK,
    EXIT_PLUGIN_FAILED,
    EXIT_USAGE,
    EXIT_VIOLATION,
    verdict,
)

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: Three platforms wait for ready_event (emitted 1 s after the start), then go to Done.
TINY = """<TaskScript name="tiny">
  <_ActorsConfig>
    <Actor><_P_Name>Standby</_P_Name><OODAConfig><Bus><_P_Name>decide_bus</_P_Name>
      <Plugin><_P_Name>core.emit_after</_P_Name>
        <param key="event" value="ready_event"/><param key="after" value="1"/></Plugin>
    </Bus></OODAConfig></Actor>
    <Actor><_P_Name>Done</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
      <Plugin><_P_Name>{done}</_P_Name></Plugin></Bus></OODAConfig></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="Standby"><transition name="{event}" sysNum="all" timeout="10">
      <successor actor="Done"/></transition></actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-3" actor="Standby"/></_PlatformActorConfig>
</TaskScript>
"""

#: A plugin that fails when it starts, named by its path (the checker does not import it).
BOOM = """
from actorswarm.runtime.plugin import Plugin


class Boom(Plugin):
    any_bus = True

    def on_start(self, ctx):
        raise RuntimeError("the camera is unplugged")

    def step(self, ctx):
        pass
"""


def tiny(tmp_path: Path, *, done: str = "core.idle", event: str = "ready_event") -> Path:
    path = tmp_path / "tiny.xml"
    path.write_text(TINY.format(done=done, event=event))
    return path


def sim(*args: str) -> tuple[int, str, str]:
    result = runner.invoke(app, ["sim", *args])
    assert "Traceback" not in result.output
    return result.exit_code, result.stdout, result.stderr


def test_a_run_that_went_as_asked_exits_0(tmp_path: Path) -> None:
    code, out, err = sim(str(tiny(tmp_path)), "--no-world", "--duration", "4", "--expect-complete")
    assert code == EXIT_OK, out + err
    assert "completed: True" in out and err == ""


def test_an_unfinished_task_exits_4_only_when_completion_is_expected(tmp_path: Path) -> None:
    # The event comes after 1 s: at 0.5 s every platform still runs Standby.
    script = str(tiny(tmp_path))
    code, out, err = sim(script, "--no-world", "--duration", "0.5")
    assert code == EXIT_OK and "completed: False" in out
    code, out, err = sim(script, "--no-world", "--duration", "0.5", "--expect-complete")
    assert code == EXIT_INCOMPLETE
    assert "run failed (exit 4): the task did not complete in 0.5 s" in err


def test_a_failed_plugin_is_in_the_summary_and_exits_3(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "boomplug.py").write_text(BOOM)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "boomplug", raising=False)
    report = tmp_path / "r.json"
    code, out, err = sim(
        str(tiny(tmp_path, done="boomplug:Boom")), "--no-world", "--duration", "4",
        "--json", str(report),
    )  # fmt: skip
    assert code == EXIT_PLUGIN_FAILED, out + err
    assert "PLUGIN FAILURES: 3" in out
    lines = [line for line in out.splitlines() if "plugin boomplug:Boom" in line]
    assert len(lines) == 3
    assert all("actor Done" in line and "the camera is unplugged" in line for line in lines)
    assert "run failed (exit 3): 3 plugin failure(s)" in err
    failures = json.loads(report.read_text())["plugin_failures"]
    assert sorted(f["platform"] for f in failures) == [1, 2, 3]


def test_a_bad_param_of_a_plugin_named_by_path_is_refused_cleanly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The checker does not import module:Class paths; the runtime reads the params when the
    # script is loaded, and sim refuses them as cleanly as the checker would.
    (tmp_path / "countplug.py").write_text(
        "from actorswarm.runtime.plugin import Param, Plugin\n\n\n"
        "class Count(Plugin):\n"
        "    any_bus = True\n"
        '    params = {"n": Param(kind="int", required=True)}\n\n'
        "    def step(self, ctx):\n"
        "        pass\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "countplug", raising=False)
    script = tmp_path / "tiny.xml"
    script.write_text(
        TINY.format(done="countplug:Count", event="ready_event").replace(
            "<_P_Name>countplug:Count</_P_Name>",
            '<_P_Name>countplug:Count</_P_Name><param key="n" value="three"/>',
        )
    )
    code, out, err = sim(str(script), "--no-world", "--duration", "4")
    assert code == EXIT_USAGE and out == ""
    assert err == f"{script}: Count: n must be an integer such as 3, not 'three'\n"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--event", "redy_event@2"], "--event redy_event@2: no transition of any actor is on "
         'redy_event (did you mean "ready_event"?), so every platform would ignore it (the '
         "events the script handles: ready_event)"),
        (["--event", "ready_event@9"], "--event ready_event@9: 9 s is after the end of the run "
         "(--duration 4)"),
        (["--kill", "2@5"], "--kill 2@5: 5 s is after the end of the run (--duration 4)"),
        (["--kill", "7@1"], "--kill 7@1: the script starts no platform 7 (its platforms: 1-3)"),
        (["--event", "ready_event@1:2-5"], "--event ready_event@1: the script starts no "
         "platforms 4-5"),
        (["--partition", "3-4@1"], "--partition 3-4@1: the script starts no platform 4"),
        (["--restart", "1@4.5"], "--restart 1@4.5: 4.5 s is after the end of the run"),
    ],
)  # fmt: skip
def test_a_schedule_the_script_cannot_use_is_refused_before_the_run(
    tmp_path: Path, args: list[str], message: str
) -> None:
    code, out, err = sim(str(tiny(tmp_path)), "--no-world", "--duration", "4", *args)
    assert code == EXIT_USAGE, out + err
    assert out == ""  # nothing ran
    assert message in err


def test_every_schedule_mistake_is_said_at_once(tmp_path: Path) -> None:
    code, _, err = sim(
        str(tiny(tmp_path)), "--no-world", "--duration", "4",
        "--event", "nope@1", "--kill", "9@8",
    )  # fmt: skip
    assert code == EXIT_USAGE
    assert len(err.splitlines()) == 3  # the unknown event; the kill: too late, no platform 9


def test_a_malformed_area_is_refused_by_sim_before_it_runs(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    text = (EXAMPLES / "search_track_10.xml").read_text()
    bad.write_text(
        text.replace(
            'value="search"/><param key="altitude" value="35"',
            'value="0 0 100"/><param key="altitude" value="35"',
        )
    )
    line = next(n for n, row in enumerate(bad.read_text().splitlines(), 1) if "0 0 100" in row)
    world = str(EXAMPLES / "worlds" / "search_track_10.toml")
    code, out, err = sim(str(bad), "--world", world, "--duration", "5")
    assert code == 1 and out == ""
    assert err.startswith(f"{bad}:{line}:")
    assert "search.area: area '0 0 100' has 3 numbers, but a rectangle is four" in err
    named = tmp_path / "named.xml"
    named.write_text(
        text.replace(
            'value="search"/><param key="altitude" value="35"',
            'value="serch"/><param key="altitude" value="35"',
        )
    )
    code, out, err = sim(str(named), "--world", world, "--duration", "5")
    assert code == 1 and "the world has no area 'serch' (did you mean \"search\"?)" in err


def test_the_verdict_puts_a_violation_first_and_says_everything() -> None:
    report = {
        "violations": ["two masters in epoch 3"],
        "plugin_failures": [{"t": 1.0}],
        "completed": False,
        "sim_time_s": 9.0,
    }
    status, (line,) = verdict(report, expect_complete=True)
    assert status == EXIT_VIOLATION
    assert line.startswith("run failed (exit 1): 1 invariant(s) violated; 1 plugin failure(s); ")
    assert "did not complete in 9 s" in line
    assert verdict({**report, "violations": []})[0] == EXIT_PLUGIN_FAILED
    assert verdict({**report, "violations": [], "plugin_failures": []}) == (EXIT_OK, [])
