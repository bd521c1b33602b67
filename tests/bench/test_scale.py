"""``actorswarm bench scale``: the scenario's figures at small sizes, the report, the JSON,
the picture and the command line. Timings are never asserted (shared machines are noisy);
virtual-time figures are checked for sanity only (the core is tuned elsewhere)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from actorswarm.bench.scale import (
    ScaleCell,
    ScaleReport,
    Scenario,
    run_cell,
    run_scale,
    to_json,
)
from actorswarm.bench.scale_report import markdown, plot_scale, problems
from actorswarm.cli.app import app

#: The scenario squeezed into 4 s of virtual time: the quiet window 1–2 s, the barrier at
#: 2 s, the crash at 3 s (a failover takes well under a second without loss).
SHORT = Scenario(quiet_from=1.0, barrier_at=2.0, crash_at=3.0, end=4.0)
SHORT_ARGS = ["--quiet-from", "1", "--barrier-at", "2", "--crash-at", "3", "--end", "4"]


def _strict(text: str) -> Any:
    """JSON that must not hold NaN or infinities (they are written as null)."""

    def refuse(name: str) -> None:
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("membership", ["broadcast", "star"])
@pytest.mark.parametrize("size", [5, 20])
def test_a_cell_at_a_small_size_is_sane(membership: Any, size: int) -> None:
    cell = run_cell(membership, size, 0.0, seed=3, scenario=SHORT)
    assert cell.errors == [], cell.errors
    assert (cell.membership, cell.size, cell.loss, cell.seed) == (membership, size, 0.0, 3)
    assert not cell.over_budget and cell.reached_s == SHORT.end
    assert cell.wall_s > 0 and cell.sim_per_wall > 0
    assert 0 < cell.formed_at_s < SHORT.quiet_from  # formed before the quiet window
    assert cell.expected == size and cell.released == size and cell.all_released
    assert cell.master >= 1 and cell.old_master == cell.master  # the crash took the master
    assert cell.new_master not in (-1, cell.old_master)
    # The new master cannot be known before the crash, and is well within the run.
    assert 0 < cell.failover_ms < (SHORT.end - SHORT.crash_at) * 1000
    for rate in (cell.member_recv_pps, cell.master_recv_pps, cell.air_pps, cell.air_kbps):
        assert math.isfinite(rate) and rate > 0
    assert cell.member_recv_pps_min <= cell.member_recv_pps <= cell.member_recv_pps_max
    # The master hears every member; a non-master hears no more than that.
    assert cell.master_recv_pps >= cell.member_recv_pps
    # Without loss nobody alive is declared gone.
    assert cell.false_leaves == 0 and cell.false_leaves_per_member_hour == 0.0
    assert cell.member_hours == pytest.approx((size - 1) * SHORT.window / 3600)
    assert cell.violations == 0


def test_a_cell_is_replayed_exactly_from_its_seed() -> None:
    first = run_cell("broadcast", 6, 0.1, seed=7, scenario=SHORT)
    again = run_cell("broadcast", 6, 0.1, seed=7, scenario=SHORT)
    wall = {"wall_s", "peak_rss_mib"}  # the machine's, not the run's
    figures = {k: v for k, v in to_json(_report([first]))["cells"][0].items() if k not in wall}
    replay = {k: v for k, v in to_json(_report([again]))["cells"][0].items() if k not in wall}
    figures.pop("sim_s_per_wall_s")
    replay.pop("sim_s_per_wall_s")
    assert figures == replay


def test_a_cell_over_its_wall_budget_is_abandoned_and_says_where() -> None:
    tight = Scenario(quiet_from=1.0, barrier_at=2.0, crash_at=3.0, end=4.0, max_wall=1e-9)
    cell = run_cell("broadcast", 5, 0.0, seed=1, scenario=tight)
    assert cell.over_budget and cell.reached_s < tight.end
    assert cell.errors[0].startswith("over budget: abandoned at t = ")
    assert math.isnan(cell.failover_ms) and cell.violations == -1
    text = markdown(_report([cell]))
    assert f"(over budget at {cell.reached_s:.1f} s)" in text
    assert f"- broadcast N=5 loss=0%: {cell.errors[0]}" in text


def test_the_scenario_must_be_in_order() -> None:
    with pytest.raises(ValueError, match="quiet window start < barrier < crash < end"):
        Scenario(quiet_from=2.0, barrier_at=4.0, crash_at=3.0, end=8.0)
    with pytest.raises(ValueError, match="max_wall"):
        Scenario(max_wall=0.0)
    with pytest.raises(ValueError, match="at least 2 platforms"):
        run_cell("broadcast", 1, 0.0, seed=1, scenario=SHORT)


def _report(cells: list[ScaleCell]) -> ScaleReport:
    return ScaleReport(
        command="actorswarm bench scale",
        started="2026-11-22T00:00:00Z",
        machine={"cpus": 2},
        scenario=SHORT,
        cells=cells,
        wall_s=1.0,
    )


def test_the_report_json_and_picture_of_a_run(tmp_path: Path) -> None:
    seen: list[str] = []
    report = run_scale(
        ["star", "broadcast"],
        [5, 8],
        [0.0],
        seed=2,
        scenario=SHORT,
        command="actorswarm bench scale --sizes 5,8",
        done=lambda so_far, cell: seen.append(cell.label),
    )
    # Both schemes of one size one after the other, with the same seed.
    assert seen == ["star N=5 loss=0%", "broadcast N=5 loss=0%", "star N=8 loss=0%",
                    "broadcast N=8 loss=0%"]  # fmt: skip
    assert report.cells[0].seed == report.cells[1].seed != report.cells[2].seed
    text = markdown(report)
    assert text.startswith("# Benchmark: what the swarm size costs")
    assert "Command: `actorswarm bench scale --sizes 5,8`" in text
    rows = [line for line in text.splitlines() if line.startswith("| ")]
    assert rows[0].startswith("| membership | N | loss | wall s | sim s / wall s | peak MiB |")
    assert len(rows) == 5 and all(line.count("|") == 15 for line in rows)
    assert rows[1].startswith("| broadcast | 5 | 0% |") and "| yes |" in rows[1]
    assert rows[2].startswith("| star | 5 | 0% |")
    data = _strict(json.dumps(to_json(report), allow_nan=False))
    assert data["scenario"]["barrier_at"] == 2.0 and data["protocol"]["heartbeat_ms"] == 100.0
    assert [(c["membership"], c["size"]) for c in data["cells"]] == [
        ("star", 5), ("broadcast", 5), ("star", 8), ("broadcast", 8),
    ]  # fmt: skip
    for cell in data["cells"]:
        assert cell["all_released"] is True and cell["failover_ms"] > 0
        assert cell["member_recv_pps"] > 0 and cell["sim_s_per_wall_s"] > 0
        # This process's interpreter and the swarm: tens of MiB, never nothing.
        assert 10 < cell["peak_rss_mib"] < 4096
    plot_scale(report, tmp_path / "scale.png")
    assert (tmp_path / "scale.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    plot_scale(_report([]), tmp_path / "empty.png")  # nothing measured: the panels say so
    assert (tmp_path / "empty.png").stat().st_size > 0
    assert problems(report) == []


def test_the_command_writes_the_report_json_and_picture(tmp_path: Path) -> None:
    md, js, png = tmp_path / "scale.md", tmp_path / "scale.json", tmp_path / "scale.png"
    args = ["bench", "scale", "--sizes", "5,6", "--membership", "broadcast", "--loss", "0,10%"]
    args += [*SHORT_ARGS, "--out", str(md), "--json", str(js), "--plot", str(png)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    text = md.read_text()
    # The command at the top names every option, so the run can be made again.
    assert (
        "Command: `actorswarm bench scale --sizes 5,6 --membership broadcast --loss 0,0.1 "
        "--seed 1 --max-wall 600 --quiet-from 1 --barrier-at 2 --crash-at 3 --end 4 --out "
    ) in text
    assert text in result.stdout  # the report goes to stdout too
    data = _strict(js.read_text())
    assert data["cut_short"] == ""
    cells = [(c["membership"], c["size"], c["loss"]) for c in data["cells"]]
    assert cells == [("broadcast", n, loss) for loss in (0.0, 0.1) for n in (5, 6)]
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--sizes", "5,x"], "expected comma-separated integers"),
        (["--sizes", "1,10"], "every size must be 2..10000"),
        (["--sizes", "20000"], "every size must be 2..10000"),
        (["--sizes", ""], "every size must be 2..10000"),
        (["--loss", "1.5"], "every rate must be at least 0 and below 1"),
        (["--membership", "mesh"], "mesh"),
        (["--crash-at", "3"], "quiet window start < barrier < crash < end"),
    ],
)
def test_bad_arguments_get_a_clear_error(args: list[str], message: str) -> None:
    result = CliRunner().invoke(app, ["bench", "scale", *args])
    assert result.exit_code == 2
    # The terminal box may wrap the message: compare it as one line.
    said = " ".join(result.output.replace("│", " ").split())
    assert message in said
