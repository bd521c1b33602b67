"""The command line: the demo (the main job), the campaign replay and the benchmark."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app

runner = CliRunner()


def test_demo_runs_and_every_invariant_holds(tmp_path: Path) -> None:
    out = tmp_path / "demo.json"
    result = runner.invoke(app, ["swarm", "demo", "--json", str(out)])
    assert result.exit_code == 0, result.output
    assert "every invariant held" in result.output
    report = json.loads(out.read_text())
    assert report["violations"] == [] and report["problems"] == []
    masters = [m["platform"] for m in report["masters"]]
    assert masters[0] == 1, "the lowest ID is elected first"
    assert len(set(masters)) >= 2, "the master crash elects another"
    assert report["barrier_passes"] > 100


def test_campaign_replays_one_seed() -> None:
    result = runner.invoke(app, ["swarm", "campaign", "--seed", "3"])
    assert result.exit_code == 0, result.output
    assert "seed 3:" in result.output and "1 passed, 0 failed" in result.output


def test_bench_core_writes_a_table(tmp_path: Path) -> None:
    out = tmp_path / "core.md"
    result = runner.invoke(
        app, ["bench", "core", "--sizes", "5", "--repeats", "1", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    table = out.read_text()
    assert "| 5 | 1 |" in table and "barrier" in table


def test_bad_sizes_get_a_clear_error() -> None:
    result = runner.invoke(app, ["bench", "core", "--sizes", "5,x"])
    assert result.exit_code == 2
    assert "--sizes" in result.output


def test_python_dash_m_works() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "actorswarm", "version"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 0 and proc.stdout.startswith("actorswarm ")


def test_bench_plot_redraws_a_saved_run(tmp_path: Path) -> None:
    raw = tmp_path / "core.json"
    result = runner.invoke(
        app, ["bench", "core", "--sizes", "4,6", "--repeats", "1", "--json", str(raw)]
    )
    assert result.exit_code == 0, result.output
    png = tmp_path / "core.png"
    result = runner.invoke(app, ["bench", "plot", str(raw), "--out", str(png)])
    assert result.exit_code == 0, result.output
    assert png.read_bytes().startswith(b"\x89PNG"), "a PNG picture"
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    result = runner.invoke(app, ["bench", "plot", str(bad), "--out", str(png)])
    assert result.exit_code == 2 and "not a bench core result file" in result.output


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_sim_json_to_stdout_has_the_report_keys() -> None:
    result = runner.invoke(
        app,
        [
            "sim",
            str(EXAMPLES / "branch_merge.xml"),
            "--no-world",
            "--event",
            "AtoBC_branch_event@5",
            "--event",
            "finish_event@10",
            "--duration",
            "12",
            "--json",
            "-",
        ],
    )
    assert result.exit_code == 0, result.output
    report = json.loads(result.output)
    for key in ("completed", "sim_time_s", "final_actors", "transitions", "masters", "traffic"):
        assert key in report
    assert report["violations"] == []
    moves = [(t["from"], t["to"]) for t in report["transitions"] if t["cause"] == "barrier"]
    assert moves.count(("A", "B")) == 2 and moves.count(("A", "C")) == 8
    assert moves.count(("B", "A")) + moves.count(("C", "A")) == 10


def test_sim_prints_a_summary_and_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    result = runner.invoke(
        app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--no-world", "--json", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "Standby → Ingress" in result.output and "invariants: all held" in result.output
    assert json.loads(out.read_text())["completed"] is True


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--event", "nope"], "--event: expected NAME@T"),
        (["--event", "go@-1"], "--event: the time must be >= 0"),
        (["--kill", "3"], "--kill: expected ID@T"),
        (["--partition", "5-1@2"], "--partition:"),
        (["--heal", "3@4"], "--heal: expected @T"),
    ],
)
def test_sim_refuses_bad_flags_clearly(args: list[str], message: str) -> None:
    result = runner.invoke(app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--no-world", *args])
    assert result.exit_code == 2, result.output
    assert message in result.output


def test_sim_runs_in_the_default_world_or_a_given_one(tmp_path: Path) -> None:
    result = runner.invoke(app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--duration", "5"])
    assert result.exit_code == 0 and "invariants: all held" in result.output, result.output
    world = EXAMPLES / "worlds" / "default.toml"
    result = runner.invoke(
        app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--world", str(world), "--duration", "5"]
    )
    assert result.exit_code == 0, result.output
    bad = tmp_path / "bad.toml"
    bad.write_text("[radio]\nrnage = 10\n")
    result = runner.invoke(app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--world", str(bad)])
    assert result.exit_code == 2 and "rnage" in result.output
    result = runner.invoke(
        app, ["sim", str(EXAMPLES / "ready_barrier.xml"), "--world", str(world), "--no-world"]
    )
    assert result.exit_code == 2 and "exclude each other" in result.output


def test_bench_switch_rows(tmp_path: Path) -> None:
    out = tmp_path / "switch.json"
    result = runner.invoke(
        app, ["bench", "switch", "--plugins", "1,5", "--runs", "20", "--json", str(out)]
    )
    assert result.exit_code == 0, result.output
    rows = json.loads(out.read_text())
    assert {(r["plugins"], r["mode"]) for r in rows} == {
        (1, "cold"),
        (1, "warm"),
        (5, "cold"),
        (5, "warm"),
    }
    assert all(r["median_ms"] > 0 and r["p99_ms"] >= r["median_ms"] for r in rows)


def test_sim_records_and_plot_draws(tmp_path: Path) -> None:
    rec = tmp_path / "run.mcap"
    result = runner.invoke(
        app,
        [
            "sim",
            str(EXAMPLES / "takeoff_ingress_return.xml"),
            "--duration",
            "40",
            "--record",
            str(rec),
        ],
    )
    assert result.exit_code == 0, result.output
    assert rec.read_bytes().startswith(b"\x89MCAP0\r\n")
    result = runner.invoke(app, ["plot", str(rec), "--out", str(tmp_path / "pics")])
    assert result.exit_code == 0, result.output
    for name in ("run-trajectories.png", "run-timeline.png"):
        assert (tmp_path / "pics" / name).read_bytes().startswith(b"\x89PNG")
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    result = runner.invoke(app, ["plot", str(bad)])
    assert result.exit_code == 2 and "line 1" in result.output


def test_demo_command_runs_a_mission_and_writes_its_pictures(tmp_path: Path) -> None:
    """The main job, on a small swarm so the test stays quick: the search-and-track mission
    with 4 quadrotors (the full 30-UAV formation run is in tests/sim/test_missions.py)."""
    out = tmp_path / "demo"
    result = runner.invoke(
        app, ["demo", "--mission", "search-track", "--platforms", "4", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert "Standby → Ingress" in result.output and "switched within" in result.output
    assert "summary of the search-track mission" in result.output
    for name in ("trajectories.png", "timeline.png"):
        assert (out / name).read_bytes().startswith(b"\x89PNG")
    report = json.loads((out / "report.json").read_text())
    assert report["completed"] and report["violations"] == []
    assert len(report["final_actors"]) == 4
    assert (out / "record.mcap").read_bytes().startswith(b"\x89MCAP0\r\n")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--mission", "formaton"], 'did you mean "formation"'),
        (["--kill", "3"], "ID@T"),
    ],
)
def test_demo_refuses_bad_options_clearly(args: list[str], message: str) -> None:
    result = runner.invoke(app, ["demo", *args])
    assert result.exit_code == 2
    assert message in result.output


def test_demo_lists_plugin_failures_and_exits_3_as_sim_does(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A plugin that raises on every platform: the mission still ends in Return, and the
    demo lists each failure and exits with sim's plugin-failure status."""
    from actorswarm.plugins.flight import ReturnHome
    from actorswarm.sim.verdict import EXIT_PLUGIN_FAILED

    def broken(self: ReturnHome, ctx: object) -> None:
        raise RuntimeError("the [home] beacon is silent")

    monkeypatch.setattr(ReturnHome, "step", broken)
    out = tmp_path / "demo"
    result = runner.invoke(
        app, ["demo", "--mission", "search-track", "--platforms", "2", "--out", str(out)]
    )
    assert result.exit_code == EXIT_PLUGIN_FAILED, result.output
    assert "PLUGIN FAILURES: 2" in result.stdout
    lines = [line for line in result.stdout.splitlines() if "plugin flight.return_home" in line]
    assert len(lines) == 2
    assert all("actor Return" in line and "the [home] beacon is silent" in line for line in lines)
    assert "run failed (exit 3): 2 plugin failure(s)" in result.stderr
    report = json.loads((out / "report.json").read_text())
    assert sorted(f["platform"] for f in report["plugin_failures"]) == [1, 2]
