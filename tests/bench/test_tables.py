"""``actorswarm bench table1|table2|table3|all``: the simulated rows, the report, the JSON,
the picture and the command line. Timings are reported, never asserted (shared machines
are noisy); the smoke run asserts that every table is produced and well formed."""

from __future__ import annotations

import json
import math
import shlex
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import pytest
from click.testing import Result
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from actorswarm.bench import paper
from actorswarm.bench.scripts import table1_script, table2_script
from actorswarm.bench.tables import (
    Plan,
    Table1Row,
    Table2Row,
    Table3Row,
    TableSettings,
    TablesReport,
    from_json,
    merge,
    percentile,
    summarize,
    to_json,
)
from actorswarm.bench.tables_plot import _size_labels, plot_tables
from actorswarm.bench.tables_report import markdown, problems
from actorswarm.bench.tables_sim import (
    SimBackend,
    _left_out,
    replay_command,
    sim_table1,
    sim_table2_cell,
    sim_table3,
)
from actorswarm.cli.app import app
from actorswarm.dsl import check
from actorswarm.engine.records import FiredRecord

NAN = math.nan


# --- statistics ----------------------------------------------------------------------------


@given(st.lists(st.floats(min_value=0, max_value=1e6), min_size=1, max_size=50))
def test_a_summary_orders_its_figures(values: list[float]) -> None:
    s = summarize([*values, NAN])
    assert s.n == len(values) and s.failed == 1
    assert s.lo <= s.median <= s.p95 <= s.p99 <= s.hi
    assert s.spread == s.hi - s.lo


def test_percentiles_by_nearest_rank() -> None:
    values = [float(v) for v in range(1, 101)]
    assert percentile(values, 0.95) == 95.0
    assert percentile(values, 0.99) == 99.0
    assert percentile([3.0], 0.95) == 3.0
    assert math.isnan(percentile([NAN], 0.5))
    assert summarize([NAN, NAN]).n == 0


# --- scripts -------------------------------------------------------------------------------


@pytest.mark.parametrize("plugins", [1, 5])
def test_the_benchmark_scripts_pass_the_checker(plugins: int) -> None:
    for text in (table1_script(31, plugins), table2_script(30, plugins)):
        result = check(text, path="bench.xml")
        assert result.ok, [str(d) for d in result.diagnostics]
        for actor in result.script.actors if result.script else ():
            assert len(list(actor.plugins())) == plugins


def test_a_script_with_no_plugin_is_refused() -> None:
    with pytest.raises(ValueError, match="at least one plugin"):
        table2_script(5, 0)


# --- the simulated rows --------------------------------------------------------------------


def test_simulated_transitions_are_measured_and_replayable() -> None:
    settings = SimBackend(TableSettings(repeat=3))
    row = sim_table2_cell("switch", 6, 1, 0.0, settings)
    again = sim_table2_cell("switch", 6, 1, 0.0, settings)
    assert row == again  # virtual time: the same seed gives the same figures
    assert row.errors == []
    for values in (row.transition_ms, row.master_pps, row.member_pps, row.bytes_per_packet):
        assert len(values) == 3 and all(v > 0 for v in values)
    # Three hops at least (ground station → platforms → master → platforms), 10 ms each.
    assert min(row.transition_ms) >= 30.0
    # The master hears every request: more packets than an average member.
    assert all(m > n for m, n in zip(row.master_packets, row.member_packets, strict=True))
    branch = sim_table2_cell("branch", 6, 5, 0.1, settings)
    assert branch.errors == [] and len(branch.transition_ms) == 3
    assert all(not math.isnan(v) for v in branch.transition_ms)


def test_a_platform_left_out_of_a_release_fails_the_repetition_at_once() -> None:
    # Under 30 % loss, before suspicion and loss-aware leave times, platform 3 was declared
    # gone during this switch, missed the release and was "not chosen" when it asked again.
    # Now all 8 cross; the rule that fails such a repetition at once is checked below.
    row = sim_table2_cell("switch", 8, 1, 0.3, SimBackend(TableSettings(repeat=1, seed=12)))
    assert not row.errors and not math.isnan(row.transition_ms[0]), row.errors
    fired = [FiredRecord(t=1.0, key=1, generation=1, outcome="complete", chosen=(1, 2))]
    all_switched = {1: 1.01, 2: 1.02}
    assert _left_out(fired, [1, 2, 3], all_switched, now=2.0) == [3]
    assert _left_out(fired, [1, 2, 3], all_switched, now=1.5) == []  # not a second yet
    assert _left_out(fired, [1, 2, 3], {1: 1.01}, now=2.0) == []  # 2 still on its way
    assert _left_out(fired, [1, 2], all_switched, now=2.0) == []
    assert _left_out([], [1, 2, 3], {}, now=9.0) == []  # not released yet


@pytest.mark.parametrize("table", ["table2", "table3"])
def test_a_rows_replay_command_measures_it_again_exactly(table: str) -> None:
    settings = SimBackend(TableSettings(repeat=2, seed=5))
    if table == "table2":
        row: Table2Row | Table3Row = sim_table2_cell("switch", 3, 1, 0.1, settings)
        command = replay_command(table, 3, 0.1, settings, cases="switch", plugins=1)
    else:
        row = sim_table3([(3, 0.1)], settings)[0]
        command = replay_command(table, 3, 0.1, settings)
    assert command.startswith(f"actorswarm bench {table} --mode sim --sizes 3 --big-sizes ''")
    result = CliRunner().invoke(app, [*shlex.split(command)[1:], "--json", "-"])
    assert result.exit_code == 0, result.output
    again = from_json(json.loads(result.stdout[result.stdout.index("{") :]))
    rows = again.table2 if table == "table2" else again.table3
    assert [(r.size, r.loss) for r in rows] == [(3, 0.0), (3, 0.1)]  # the loss-free row first
    # Every measured figure, the same (NaN written alike, so compared as JSON text).
    assert json.dumps(asdict(rows[1])) == json.dumps(asdict(row))
    assert replay_command("table3", 1000, 0.3, SimBackend(big_repeat=2)) == (
        "actorswarm bench table3 --mode sim --sizes 1000 --big-sizes '' --loss 0.3 "
        "--big-repeat 2 --seed 1 --membership star"
    )


def test_a_transition_that_never_completes_is_a_failed_sample_with_a_replay_line() -> None:
    # Nine of ten packets lost: a barrier of every platform cannot complete in 0.3 s.
    settings = SimBackend(TableSettings(repeat=2), run_timeout=0.3)
    row = sim_table2_cell("switch", 5, 1, 0.9, settings)
    assert len(row.transition_ms) == 2
    assert any(math.isnan(v) for v in row.transition_ms)
    assert any("replay: actorswarm bench table2 --mode sim" in e for e in row.errors)


def test_the_membership_scheme_reaches_the_core_and_the_report(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--membership both: every simulated row of Tables II and III is measured in each
    scheme, with a CoreConfig of that scheme; the JSON and the report name the scheme of
    each row, and a failed row's replay command asks for it."""
    from actorswarm.bench import tables_sim
    from actorswarm.bench.core import FailoverRun

    built: list[str] = []
    task_sim = tables_sim.TaskSim

    def spy(*args: Any, **kwargs: Any) -> Any:
        built.append(kwargs["config"].membership)
        return task_sim(*args, **kwargs)

    monkeypatch.setattr(tables_sim, "TaskSim", spy)
    row = sim_table2_cell(
        "switch", 3, 1, 0.0, SimBackend(TableSettings(repeat=1), membership="broadcast")
    )
    assert built == ["broadcast"] and row.membership == "broadcast"
    assert row.errors == [] and len(row.transition_ms) == 1

    asked: list[str] = []

    def failover(size: int, seed: int, link: Any, config: Any) -> Any:
        asked.append(config.membership)
        if config.membership == "broadcast":  # a failed repetition, to see its replay line
            return FailoverRun(to_claim=NAN, to_acknowledged=NAN, new_master=-1), []
        return FailoverRun(to_claim=0.45, to_acknowledged=0.5, new_master=2), []

    monkeypatch.setattr(tables_sim, "run_failover", failover)
    args = ["bench", "table3", "--mode", "sim", "--sizes", "3", "--big-sizes", "", "--loss", ""]
    args += ["--repeat", "2", "--membership", "both", "--out", str(tmp_path)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert asked == ["star", "star", "broadcast", "broadcast"]
    data = json.loads((tmp_path / "tables.json").read_text())
    assert [(r["size"], r["membership"]) for r in data["table3"]] == [(3, "star"), (3, "broadcast")]
    assert data["settings"]["memberships"] == ["star", "broadcast"]
    text = (tmp_path / "tables.md").read_text()
    assert "| mode | membership | N | loss | runs ok |" in text
    assert "| sim | star | 3 | 0% | 2/2 | 500 (500; 500–500) |" in text
    assert "| sim | broadcast | 3 | 0% | 0/2 | — |" in text
    (failed, *_) = problems(from_json(data))
    assert failed.startswith("III sim membership=broadcast N=3 loss=0%: no new master")
    assert failed.endswith("--repeat 2 --seed 1 --membership broadcast)")
    assert (tmp_path / "tables.png").exists()
    # One scheme only: no column, the scheme is named once above the tables.
    single = markdown(_report())
    assert "Tables II and III ran with the `star` membership scheme" in single
    assert "| membership |" not in single
    # A row saved before rows had a scheme was measured with the only one there was.
    old = to_json(_report())
    for saved in old["table2"] + old["table3"]:
        del saved["membership"]
    assert {r.membership for r in from_json(old).table3} == {"broadcast"}


def test_simulated_failover_and_overhead_rows() -> None:
    settings = SimBackend(TableSettings(repeat=2, peers=4, window=3.0))
    (iii,) = sim_table3([(5, 0.1)], settings)
    assert iii.errors == [] and len(iii.election_ms) == 2
    # A new master cannot be known before the old one is declared gone (T_leave 500 ms).
    assert all(v >= 400 for v in iii.election_ms)
    (i,) = sim_table1([1], settings)
    assert i.peers == 4 and len(i.cpu_pct) == 2 and all(v > 0 for v in i.cpu_pct)
    assert i.rss_mib == []  # one process hosts every simulated platform
    # Five platforms alternating at 1 Hz for 6 s: each switched about six times.
    assert len(i.switch_ms) >= 20 and all(v >= 0 for v in i.switch_ms)


# --- report, JSON, picture -----------------------------------------------------------------


def _report() -> TablesReport:
    return TablesReport(
        command="actorswarm bench all",
        started="2026-11-22T00:00:00Z",
        machine={"cpus": 2},
        radio={"latency_ms": 10},
        settings={},
        table1=[Table1Row("real", 1, 30, [0.9, 1.1], [70.0, 71.0], [0.05, 0.07, 0.2])],
        table2=[
            Table2Row("sim", "switch", 30, 1, 0.0, [44.0, 46.0], [2000.0] * 2, [500.0] * 2,
                      [50.0] * 2, [100.0] * 2, [20.0] * 2),
            Table2Row("sim", "branch", 5, 1, 0.0, [40.0, NAN], [200.0, NAN], [150.0, NAN],
                      [48.0, NAN], [9.0, NAN], [6.0, NAN], ["split: 1 of 2 switched"]),
            Table2Row("sim", "switch", 1000, 1, 0.3, [500.0], [9e3], [800.0], [50.0],
                      [3000.0], [400.0]),
        ],
        table3=[Table3Row("real", 30, 0.0, [450.0, 470.0]), Table3Row("sim", 7, 0.1, [NAN])],
        wall_s=12.0,
    )  # fmt: skip


def test_the_report_puts_the_paper_next_to_ours() -> None:
    text = markdown(_report())
    for heading in ("## Table I", "## Table II(a)", "## Table II(b)", "## Table III"):
        assert heading in text
    # Table II(a), N=30, one plugin: ours 45 ms against the paper's 1332 ms.
    assert "| sim | 30 | 1 | 0% | 2/2 | 45.0 (46.0; 44.0–46.0) | 1,332 | 0.0338 |" in text
    assert "| real | 30 | 0% | 2/2 | 460 (470; 450–470) | 909 | 0.506 |" in text
    # No paper figure for a lossy row or a size the paper did not measure.
    assert "| sim | 1000 | 1 | 30% | 1/1 | 500.0 (500.0; 500.0–500.0) |  |  |" in text
    assert "| sim | 5 | 1 | 0% | 1/2 |" in text  # the failed repetition is counted
    assert "II branch sim N=5 plugins=1 loss=0%: split: 1 of 2 switched" in text
    assert problems(_report()) == ["II branch sim N=5 plugins=1 loss=0%: split: 1 of 2 switched"]
    assert f"{paper.TABLE1[1].switch_ms:g} ms" in text


def test_the_json_is_strict_and_round_trips() -> None:
    report = _report()
    data = json.loads(json.dumps(to_json(report), allow_nan=False))
    assert data["table2"][1]["transition_ms"] == [40.0, None]
    assert data["table2"][0]["summary"]["transition_ms"]["median"] == 45.0
    back = from_json(data)
    assert back.table1 == report.table1 and back.table3[0] == report.table3[0]
    assert math.isnan(back.table2[1].transition_ms[1])
    assert markdown(back) == markdown(report)


def test_the_picture_is_drawn(tmp_path: Path) -> None:
    out = tmp_path / "tables.png"
    plot_tables(_report(), out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # Size ticks that would run into each other on the log axis lose their label.
    assert _size_labels([5, 10, 15, 20, 25, 30, 100, 1000]) == [
        "5", "10", "15", "20", "", "30", "100", "1000",
    ]  # fmt: skip
    empty = TablesReport("c", "s", {}, {}, {})
    plot_tables(empty, tmp_path / "empty.png")  # nothing measured: panels say so
    assert (tmp_path / "empty.png").stat().st_size > 0


# --- the command line ----------------------------------------------------------------------


def test_the_plan_adds_the_rows_beyond_the_paper() -> None:
    kwargs: dict[str, Any] = {
        "tables": ("2", "3"),
        "modes": ("sim",),
        "sizes": [5, 30],
        "big_sizes": [1000],
        "plugins": [1, 5],
        "losses": [0.1],
        "repeat": 10,
        "big_repeat": 3,
        "peers": 30,
        "window": 10.0,
        "seed": 1,
    }
    plan = Plan(**kwargs)
    assert ("branch", 30, 5, 0.0) in plan.cells2
    assert ("switch", 1000, 1, 0.0) in plan.cells2 and ("switch", 1000, 1, 0.1) in plan.cells2
    assert ("switch", 5, 1, 0.1) in plan.cells2
    assert ("branch", 1000, 1, 0.0) not in plan.cells2  # II(b) only at the paper's sizes
    assert len(plan.cells2) == len(set(plan.cells2))
    assert plan.cells3 == [(5, 0.0), (30, 0.0), (1000, 0.0), (5, 0.1), (30, 0.1), (1000, 0.1)]
    # One case only: a long run at 1000 platforms need not measure what it does not want.
    switch = Plan(**{**kwargs, "cases": ("switch",)})
    assert {c[0] for c in switch.cells2} == {"switch"}
    assert switch.cells2 == [c for c in plan.cells2 if c[0] == "switch"]
    branch = Plan(**{**kwargs, "cases": ("branch",)})
    assert branch.cells2 == [c for c in plan.cells2 if c[0] == "branch"]
    assert branch.cells3 == plan.cells3


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["table2", "--sizes", "5,x"], "comma-separated integers"),
        (["table2", "--sizes", "1"], "2..10000"),
        (["table3", "--loss", "0.1,1.5"], "above 0 and below 1"),
        (["table9"], "No such command"),
        (["all", "--mode", "fast"], "fast"),
        (["table2", "--cases", "switch,merge"], "expected switch, branch or both"),
        (["table2", "--membership", "mesh"], "mesh"),
        (["table1", "--membership", "broadcast"], "only Tables II and III choose"),
    ],
)
def test_bad_arguments_get_a_clear_error(args: list[str], message: str) -> None:
    result = CliRunner().invoke(app, ["bench", *args])
    assert result.exit_code == 2
    assert message in result.output


def _as_if_real(self: object, plan: Plan, progress: Any) -> Any:
    """Stands in for ``DaemonBackend.rows``: the simulator's rows at no loss, tagged real.
    The daemons themselves are measured by tests/bench/test_tables_real.py (Tables I, II
    and III with three daemons); this keeps the smoke run's minute of daemons out."""
    for batch in SimBackend(plan.settings()).rows(plan, progress):
        yield [replace(r, mode="real") for r in batch if getattr(r, "loss", 0.0) == 0.0]


def test_the_quick_run_produces_every_table_well_formed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The CI smoke run of both modes: every table, report, JSON, picture; the real rows
    next to the simulated ones in each table."""
    from actorswarm.bench import tables_real

    monkeypatch.setattr(tables_real.DaemonBackend, "rows", _as_if_real)
    result = CliRunner().invoke(app, ["bench", "all", "--quick", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    data = json.loads((tmp_path / "tables.json").read_text())
    report = from_json(data)
    assert {(r.mode, r.plugins) for r in report.table1} == {("sim", 1), ("real", 1)}
    cases = {(r.mode, r.case, r.size) for r in report.table2 if r.loss == 0}
    assert cases == {
        (m, c, n) for m in ("sim", "real") for c in ("switch", "branch") for n in (3, 5)
    }
    assert {(r.size, r.loss) for r in report.table2 if r.mode == "sim" and r.loss} == {
        (3, 0.1),
        (5, 0.1),
    }
    assert {(r.mode, r.size, r.loss) for r in report.table3} == {
        ("sim", 3, 0.0), ("sim", 5, 0.0), ("sim", 3, 0.1), ("sim", 5, 0.1),
        ("real", 3, 0.0), ("real", 5, 0.0),
    }  # fmt: skip
    for row in report.table2:
        lengths = {len(getattr(row, f)) for f in ("transition_ms", "master_pps", "member_pps")}
        assert lengths == {2}, row
    for row3 in report.table3:
        assert len(row3.election_ms) == 2
    for row1 in report.table1:
        assert len(row1.cpu_pct) == 2
    # The simulated rows are deterministic: they must have worked.
    assert all(not r.errors for r in report.table2 + report.table3 if r.mode == "sim")  # type: ignore[operator]
    text = (tmp_path / "tables.md").read_text()
    assert text == markdown(report)
    assert (tmp_path / "tables.png").read_bytes()[:4] == b"\x89PNG"


def test_saved_runs_are_reported_again_merged(tmp_path: Path) -> None:
    first, second = _report(), _report()
    second.command, second.table1, second.wall_s = "actorswarm bench table3", [], 3.0
    # The second run measured Table II(a) at 30 again, III at 7 again, and III at 100.
    second.table2 = [Table2Row("sim", "switch", 30, 1, 0.0, [43.0])]
    second.table3 = [Table3Row("sim", 7, 0.1, [480.0]), Table3Row("sim", 100, 0.0, [500.0])]
    paths = []
    for i, report in enumerate((first, second)):
        path = tmp_path / f"run{i}.json"
        path.write_text(json.dumps(to_json(report)))
        paths.append(str(path))
    out = tmp_path / "merged"
    result = CliRunner().invoke(app, ["bench", "report", *paths, "--out", str(out)])
    assert result.exit_code == 0, result.output
    merged = from_json(json.loads((out / "tables.json").read_text()))
    assert merged.command == "actorswarm bench all; actorswarm bench table3"
    assert len(merged.table1) == 1 and merged.wall_s == 15.0
    # A row measured again replaces the earlier one, where the earlier one was.
    assert [(r.case, r.size, r.transition_ms[0]) for r in merged.table2] == [
        ("switch", 30, 43.0),
        ("branch", 5, 40.0),
        ("switch", 1000, 500.0),
    ]
    assert [(r.size, r.election_ms) for r in merged.table3] == [
        (30, [450.0, 470.0]),
        (7, [480.0]),
        (100, [500.0]),
    ]
    assert "2 row(s) measured again in a later file replace the earlier" in result.output
    # A merged report merged again keeps its runs' settings in one flat list.
    assert len(merge([merged, first]).settings["runs"]) == 3
    assert (out / "tables.png").exists() and "## Table III" in (out / "tables.md").read_text()
    # FILE:MODE takes only that mode's rows of the file (a run redone in one mode).
    picked_json = tmp_path / "picked.json"
    args = ["bench", "report", paths[0], f"{paths[1]}:sim", "--json", str(picked_json)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    picked = from_json(json.loads(picked_json.read_text()))
    assert [r.mode for r in picked.table3] == ["real", "sim", "sim"]
    assert picked.command.endswith("actorswarm bench table3  (its sim rows)")


def test_a_file_that_is_not_a_saved_run_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"command": 1}')

    def said(result: Result) -> str:
        """The error as one line (the terminal box wraps long paths)."""
        return " ".join(result.output.replace("│", " ").split())

    result = CliRunner().invoke(app, ["bench", "report", str(bad)])
    assert result.exit_code == 2 and "not a bench tables result" in said(result)
    result = CliRunner().invoke(app, ["bench", "report", str(tmp_path / "missing.json")])
    assert result.exit_code == 2 and "No such file" in said(result)


def test_a_long_run_saves_its_rows_as_it_goes_and_when_cut_short(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The JSON is rewritten after every row ("in progress"); a run stopped by a signal
    writes its whole report so far, marked, and exits as the signal asked."""
    from actorswarm.bench import tables_sim

    cells: list[int] = []
    seen: list[TablesReport] = []
    measure = tables_sim.sim_table3

    def second_cell_interrupted(cells3: Any, settings: Any, progress: Any) -> Any:
        cells.append(cells3[0][0])
        if len(cells) == 2:
            # What has been saved is the first row, marked as a run in progress.
            seen.append(from_json(json.loads((tmp_path / "tables.json").read_text())))
            raise SystemExit(143)  # what the SIGTERM handler raises
        return measure(cells3, settings, progress)

    monkeypatch.setattr(tables_sim, "sim_table3", second_cell_interrupted)
    args = ["bench", "table3", "--mode", "sim", "--sizes", "3,4", "--loss", "", "--repeat", "1"]
    result = CliRunner().invoke(app, [*args, "--big-sizes", "", "--out", str(tmp_path)])
    assert result.exit_code == 143, result.output
    assert cells == [3, 4]
    assert [r.size for r in seen[0].table3] == [3]
    assert seen[0].cut_short == "in progress after 1 row(s)"
    cut = from_json(json.loads((tmp_path / "tables.json").read_text()))
    assert [r.size for r in cut.table3] == [3] and len(cut.table3[0].election_ms) == 1
    assert cut.cut_short == "interrupted (exit 143) after 1 row(s)"
    text = (tmp_path / "tables.md").read_text()
    assert text == markdown(cut)
    assert "**Not a complete run** (interrupted (exit 143) after 1 row(s))" in text
    assert problems(cut)[0] == "the run was cut short: interrupted (exit 143) after 1 row(s)"
    assert (tmp_path / "tables.png").exists()
    # A finished run is not marked; merged with a cut one, the mark names the cut run.
    whole = _report()
    assert not whole.cut_short and not any("cut short" in p for p in problems(whole))
    assert merge([whole, cut]).cut_short == f"{cut.command}: {cut.cut_short}"
    data = to_json(whole)
    del data["cut_short"]  # a run saved before runs could be cut short
    assert from_json(data).cut_short == ""
