"""``actorswarm task check`` and ``actorswarm task graph`` (docs/design.md §7)."""

from __future__ import annotations

import re
from pathlib import Path

from typer.testing import CliRunner

from actorswarm.cli.app import app

runner = CliRunner()
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
BROKEN = """<TaskScript name="t">
  <_ActorsConfig><Actor><_P_Name>A</_P_Name></Actor></_ActorsConfig>
  <_TaskConfig><actor name="A"><transition name="go" sysNum="0"><successor actor="B"/>
  </transition></actor></_TaskConfig>
  <_PlatformActorConfig><platform id="1-3" actor="A"/></_PlatformActorConfig>
</TaskScript>
"""


def test_check_prints_one_ok_line_per_valid_file() -> None:
    files = sorted(EXAMPLES.glob("*.xml"))
    result = runner.invoke(app, ["task", "check", *map(str, files)])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == [f"{f}: ok" for f in files]
    assert result.stderr == ""


def test_check_reports_errors_as_file_line_col_and_exits_1(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text(BROKEN)
    good = EXAMPLES / "branch_merge.xml"
    result = runner.invoke(app, ["task", "check", str(bad), str(good)])
    assert result.exit_code == 1
    assert result.stdout == f"{good}: ok\n"
    lines = result.stderr.splitlines()
    assert lines == [
        f"{bad}:3:54: sysNum must be a positive integer (how many platforms switch) "
        "or \"all\", not '0'"
    ]
    assert all(re.match(rf"{re.escape(str(bad))}:\d+:\d+: ", line) for line in lines)


def test_warnings_go_to_stderr_without_failing(tmp_path: Path) -> None:
    script = tmp_path / "warn.xml"
    script.write_text((EXAMPLES / "timeout_branch.xml").read_text().replace(' timeout="10"', ""))
    result = runner.invoke(app, ["task", "check", str(script)])
    assert result.exit_code == 0
    assert result.stdout == f"{script}: ok\n"
    assert re.fullmatch(
        rf"{re.escape(str(script))}:\d+:\d+: warning: timeoutBranch has no effect .*\n",
        result.stderr,
    )


def test_a_missing_file_exits_2_with_a_clear_message(tmp_path: Path) -> None:
    missing = tmp_path / "nope.xml"
    result = runner.invoke(app, ["task", "check", str(missing), str(EXAMPLES / "branch_merge.xml")])
    assert result.exit_code == 2
    assert result.stderr == f"{missing}: cannot read the file: No such file or directory\n"


def test_check_honours_max_bytes() -> None:
    result = runner.invoke(
        app, ["task", "check", "--max-bytes", "100", str(EXAMPLES / "branch_merge.xml")]
    )
    assert result.exit_code == 1
    assert "above the limit of 100 bytes" in result.stderr


def test_graph_prints_mermaid_by_default() -> None:
    result = runner.invoke(app, ["task", "graph", str(EXAMPLES / "branch_merge.xml")])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("stateDiagram-v2\n")
    assert "    A --> B : AtoBC_branch_event (2 of 10, key 4)\n" in result.stdout


def test_graph_prints_dot() -> None:
    result = runner.invoke(
        app, ["task", "graph", str(EXAMPLES / "branch_merge.xml"), "--format", "dot"]
    )
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith('digraph "branch-merge" {')
    assert "style=dashed" in result.stdout


def test_graph_of_a_broken_script_prints_diagnostics_and_exits_1(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xml"
    bad.write_text(BROKEN)
    result = runner.invoke(app, ["task", "graph", str(bad)])
    assert result.exit_code == 1
    assert result.stdout == ""
    assert result.stderr.startswith(f"{bad}:3:54: sysNum must be")


def test_graph_of_a_missing_file_exits_2(tmp_path: Path) -> None:
    result = runner.invoke(app, ["task", "graph", str(tmp_path / "nope.xml")])
    assert result.exit_code == 2
    assert "cannot read the file" in result.stderr


def test_check_with_a_world_judges_area_names(tmp_path: Path) -> None:
    world = EXAMPLES / "worlds" / "search_track_10.toml"
    good = EXAMPLES / "search_track_10.xml"
    bad = tmp_path / "serch.xml"
    text = good.read_text()
    bad.write_text(
        text.replace(
            '<param key="area" value="search"/><param key="altitude"',
            '<param key="area" value="serch"/><param key="altitude"',
        )
    )
    assert runner.invoke(app, ["task", "check", str(bad)]).exit_code == 0  # no world: no names
    result = runner.invoke(app, ["task", "check", "--world", str(world), str(good), str(bad)])
    assert result.exit_code == 1
    assert result.stdout == f"{good}: ok\n"
    line = next(n for n, row in enumerate(bad.read_text().splitlines(), 1) if "serch" in row)
    assert re.fullmatch(
        rf"{re.escape(str(bad))}:{line}:\d+: search\.area: the world has no area 'serch' "
        r'\(did you mean "search"\?\); its areas are field, search .*\n',
        result.stderr,
    )


def test_check_with_an_unreadable_world_exits_2(tmp_path: Path) -> None:
    world = tmp_path / "w.toml"
    world.write_text("[world]\nstep = -1\n")
    result = runner.invoke(
        app, ["task", "check", "--world", str(world), str(EXAMPLES / "branch_merge.xml")]
    )
    assert result.exit_code == 2
    assert str(world) in result.stderr and "Traceback" not in result.output
