"""``actorswarm bench scale`` on a shared channel: the options, the refusals, and small runs
that saturate a slow channel with and without the core's heartbeat cadence. Counts and
virtual-time figures only; wall times are never asserted."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
import typer
from matplotlib.figure import Figure
from typer.testing import CliRunner

from actorswarm.bench.scale import ScaleCell, ScaleReport, Scenario, run_cell, to_json
from actorswarm.bench.scale_report import markdown, plot_scale
from actorswarm.cli.app import app
from actorswarm.cli.bench_scale import Cadence, cadences, parse_bitrate
from actorswarm.core.config import CoreConfig

#: Ten platforms on a 70 kbit/s channel: at 10 Hz their heartbeats alone (about 790 bits
#: each on the air) need more than the channel has; the quiet window (3–5 s) starts after
#: the swarm formed, and a member crashes after the barrier.
SLOW = Scenario(
    quiet_from=3.0,
    barrier_at=5.0,
    member_crash_at=5.5,
    crash_at=9.0,
    end=10.0,
    channel_bitrate=70_000.0,
)


@pytest.fixture(scope="module")
def rows() -> tuple[ScaleCell, ScaleCell]:
    """The same swarm (same seed) without and with cadence."""
    off = run_cell("star", 10, 0.0, seed=1, scenario=SLOW, cadence=False)
    on = run_cell("star", 10, 0.0, seed=1, scenario=SLOW, cadence=True)
    return off, on


@pytest.mark.parametrize(
    ("text", "bps"),
    [("1000000", 1e6), ("1e6", 1e6), ("1M", 1e6), ("1m", 1e6), ("250k", 250e3),
     ("2.5 G", 2.5e9), (" 9600 ", 9600.0)],
)  # fmt: skip
def test_a_bitrate_is_read_with_its_prefix(text: str, bps: float) -> None:
    assert parse_bitrate(text) == bps


@pytest.mark.parametrize(
    ("text", "message"),
    [("fast", "expected bits per second"), ("M", "expected bits per second"),
     ("", "expected bits per second"), ("0", "must be a positive, finite"),
     ("-1k", "must be a positive, finite"), ("inf", "must be a positive, finite"),
     ("nan", "must be a positive, finite")],
)  # fmt: skip
def test_a_bad_bitrate_is_refused_by_name(text: str, message: str) -> None:
    with pytest.raises(typer.BadParameter, match=message) as caught:
        parse_bitrate(text)
    assert f"--channel-bitrate {text!r}" in str(caught.value)


def test_the_cadence_follows_the_channel() -> None:
    assert cadences(None, None) == (False,)
    assert cadences(None, 1e6) == (True,)
    assert cadences(Cadence.both, 1e6) == (False, True)
    assert cadences(Cadence.off, None) == (False,)
    with pytest.raises(typer.BadParameter, match="--cadence on: needs --channel-bitrate"):
        cadences(Cadence.on, None)


def test_the_scenario_refuses_a_bad_channel_or_member_crash() -> None:
    with pytest.raises(ValueError, match=r"Airtime\.bitrate"):
        Scenario(channel_bitrate=0.0)
    with pytest.raises(ValueError, match=r"Airtime\.overhead_bytes"):
        Scenario(channel_bitrate=1e6, overhead_bytes=-1)
    with pytest.raises(ValueError, match="the member crash"):
        Scenario(member_crash_at=3.0)  # before the barrier at 4 s
    with pytest.raises(ValueError, match="the member crash"):
        Scenario(member_crash_at=7.0)  # after the master's crash at 6 s
    with pytest.raises(ValueError, match="cadence needs a channel"):
        run_cell("star", 5, 0.0, seed=1, scenario=Scenario(), cadence=True)


def test_without_cadence_the_slow_channel_drops_heartbeats(rows: tuple[ScaleCell, ...]) -> None:
    off, _ = rows
    assert (off.channel_bitrate, off.cadence) == (70_000.0, False)
    assert off.label == "star N=10 loss=0% 70 kbit/s no cadence"
    assert 0 < off.formed_at_s < SLOW.quiet_from
    assert off.member_cadence_ms == pytest.approx(100.0)  # members at 10 Hz
    assert off.airtime_drops > 0 and off.airtime_drops_by_kind.get("Heartbeat", 0) > 0
    assert sum(off.airtime_drops_by_kind.values()) == off.airtime_drops
    assert off.run_airtime_drops >= off.airtime_drops
    # What was sent and not carried is exactly what the channel dropped.
    window = SLOW.window
    assert round((off.air_pps - off.channel_pps) * window) == off.airtime_drops
    assert 0.0 <= off.channel_utilisation <= 1.0
    # A carried packet waited at most the queue limit.
    assert 0 < off.max_wait_ms <= SLOW.max_queue_s * 1000 + 1e-6


def test_cadence_lowers_the_packets_on_the_air(rows: tuple[ScaleCell, ...]) -> None:
    off, on = rows
    assert on.cadence and on.seed == off.seed
    # The master asked its nine members for slower heartbeats (9 × 800 bits in half of
    # 70 kbit/s: 206 ms), and watches them accordingly.
    assert on.member_cadence_ms == pytest.approx(9 * 800 / (0.5 * 70_000) * 1000)
    config = CoreConfig()
    slower = on.member_cadence_ms / 1000 / config.heartbeat_interval
    assert on.leave_timeout_ms == pytest.approx(
        (config.t_leave * slower + config.probe_window) * 1000
    ), "suspicion after t_leave scaled to the cadence, then the probe window"
    assert on.air_pps < off.air_pps and on.channel_pps < off.channel_pps
    assert on.airtime_drops < off.airtime_drops
    # The heartbeats themselves are the same size either way (the cadence is not in them).
    assert on.heartbeat_bytes > 0 and off.heartbeat_bytes > 0
    assert round((on.air_pps - on.channel_pps) * SLOW.window) == on.airtime_drops


def test_the_master_declares_the_crashed_member_gone(rows: tuple[ScaleCell, ...]) -> None:
    off, on = rows
    for cell in rows:
        assert cell.crashed_member == 10  # the highest ID; platform 1 is the master
        assert 0 < cell.member_leave_ms < (SLOW.crash_at - SLOW.member_crash_at) * 1000
        # The barrier of all was requested by all ten; a member that crashes before its
        # release is no longer expected.
        assert cell.expected in (9, 10)
    assert on.run_false_leaves == 0  # its leave is not a false one
    # Not told of the channel, the master takes the drops of the overloaded channel for
    # radio loss, beats faster (``fast_master_loss``) and overloads it more: on this seed
    # it declares two live members gone (docs/deploying.md: set ``channel_bitrate``).
    assert off.run_false_leaves <= 2


def test_without_a_channel_the_load_is_still_counted() -> None:
    plain = Scenario(quiet_from=1.0, barrier_at=2.0, crash_at=3.0, end=4.0)
    cell = run_cell("star", 5, 0.0, seed=2, scenario=plain)
    assert cell.channel_bitrate is None and cell.label == "star N=5 loss=0%"
    assert cell.channel_pps == cell.air_pps > 0 and cell.channel_kbps == cell.air_kbps
    assert cell.airtime_drops == cell.run_airtime_drops == 0
    assert math.isnan(cell.channel_utilisation) and math.isnan(cell.max_wait_ms)
    assert math.isnan(cell.member_leave_ms) and cell.crashed_member == -1


def test_the_report_has_a_channel_table(
    rows: tuple[ScaleCell, ...], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    report = ScaleReport(
        command="actorswarm bench scale --channel-bitrate 70000 --cadence both",
        started="2026-11-25T00:00:00Z",
        machine={"cpus": 2},
        scenario=SLOW,
        cells=list(rows),
        wall_s=1.0,
    )
    text = markdown(report)
    assert "one radio channel of 70 kbit/s" in text and "plus 28 bytes of overhead" in text
    assert "At 5.5 s the member with the highest ID crashes" in text
    table = [line for line in text.splitlines() if line.startswith("| ")]
    assert table[0].startswith("| membership | N | loss | cadence | wall s |")
    assert table[1].startswith("| star | 10 | 0% | no |")
    assert table[2].startswith("| star | 10 | 0% | yes |")
    assert table[3].startswith("| membership | N | loss | cadence | member heartbeat ms |")
    off, on = rows
    # A heartbeat on the air: its sealed bytes and the 28 of the headers.
    bits = f"{(off.heartbeat_bytes + 28) * 8:,.0f}"
    assert table[4].startswith(f"| star | 10 | 0% | no | 100 | {bits} | {off.air_pps:.3g} |")
    assert f"| {off.airtime_drops:,} ({off.run_airtime_drops:,}) |" in table[4]
    assert table[5].startswith(f"| star | 10 | 0% | yes | {on.member_cadence_ms:,.0f} |")
    data = json.loads(json.dumps(to_json(report), allow_nan=False))
    assert data["scenario"]["channel_bitrate"] == 70_000.0
    assert [c["cadence"] for c in data["cells"]] == [False, True]
    assert data["cells"][0]["airtime_drops"] == off.airtime_drops
    # Every panel has lines: received packets, wall time and the channel's.
    drawn: list[list[int]] = []
    save = Figure.savefig

    def spy(fig: Figure, *args: Any, **kwargs: Any) -> None:
        drawn.append([len(ax.lines) for ax in fig.axes])
        save(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", spy)
    plot_scale(report, tmp_path / "channel.png")
    assert (tmp_path / "channel.png").read_bytes()[:4] == b"\x89PNG"
    assert len(drawn) == 1 and len(drawn[0]) == 3 and min(drawn[0]) > 0, drawn


def test_the_command_runs_both_cadences(tmp_path: Path) -> None:
    js = tmp_path / "channel.json"
    args = ["bench", "scale", "--sizes", "5", "--membership", "star", "--channel-bitrate", "1M"]
    args += ["--cadence", "both", "--quiet-from", "1", "--barrier-at", "2"]
    args += ["--member-crash-at", "2.5", "--crash-at", "4", "--end", "5", "--json", str(js)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    assert (
        "--barrier-at 2 --crash-at 4 --end 5 --member-crash-at 2.5 --channel-bitrate 1e+06 "
        "--overhead-bytes 28 --max-queue 1 --cadence both"
    ) in result.stdout
    data = json.loads(js.read_text())
    assert [(c["size"], c["cadence"], c["seed"]) for c in data["cells"]] == [
        (5, False, data["cells"][0]["seed"]), (5, True, data["cells"][0]["seed"]),
    ]  # fmt: skip
    for cell in data["cells"]:
        # Five platforms barely load a 1 Mbit/s channel: nothing dropped, the same cadence.
        assert cell["run_airtime_drops"] == 0 and cell["member_cadence_ms"] == 100.0
        assert cell["member_leave_ms"] > 0 and 0 < cell["channel_utilisation"] < 0.1


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--channel-bitrate", "fast"], "expected bits per second"),
        (["--channel-bitrate", "0"], "must be a positive, finite number"),
        (["--cadence", "on"], "--cadence on: needs --channel-bitrate"),
        (["--cadence", "sometimes"], "sometimes"),
        (
            ["--channel-bitrate", "1M", "--overhead-bytes", "-1"],
            "'--overhead-bytes': Input should be greater than or equal to 0",
        ),
        (
            ["--channel-bitrate", "1M", "--max-queue", "-1"],
            "'--max-queue': Input should be greater than or equal to 0",
        ),
        (["--overhead-bytes", "40"], "--overhead-bytes and --max-queue need --channel-bitrate"),
        (["--max-queue", "0.5"], "--overhead-bytes and --max-queue need --channel-bitrate"),
        (["--member-crash-at", "7"], "the member crash (7 s) must come after the barrier"),
    ],
)
def test_bad_channel_arguments_get_a_clear_error(args: list[str], message: str) -> None:
    result = CliRunner().invoke(app, ["bench", "scale", "--sizes", "5", *args])
    assert result.exit_code == 2
    said = " ".join(result.output.replace("│", " ").split())
    assert message in said


def test_a_failover_on_a_busy_shared_channel_declares_no_live_member_gone() -> None:
    """A hundred platforms on 1 Mbit/s, cadence on; the master crashes at 20 s. The new
    master's claim sets off a report from each of 98 members, queued on the channel behind
    each other for about a second. Before the new master held its inherited members (and
    they their new master) for the handshake's airtime, and reliable delivery waited for
    the swarm's packets before retrying, the new master declared 97 live members gone
    560 ms after its claim (193 false leaves over the run), and the next two successors
    claimed in turn, their master's heartbeats lost in the queue."""
    scenario = Scenario(
        quiet_from=6.0,
        barrier_at=8.0,
        member_crash_at=9.0,
        crash_at=20.0,
        end=22.0,
        channel_bitrate=1e6,
    )
    cell = run_cell("star", 100, 0.0, seed=1010103, scenario=scenario, cadence=True)
    assert cell.errors == [] and cell.all_released
    assert (cell.old_master, cell.new_master) == (1, 2)
    assert cell.run_false_leaves == 0
    assert 0 < cell.failover_ms < 1500
    # The handshake's packets had their airtime instead of being retransmitted into a
    # saturated channel: a hundred dropped over the run, not thousands.
    assert cell.run_airtime_drops < 500


def test_three_hundred_platforms_boot_pass_a_barrier_and_fail_over_on_one_megabit() -> None:
    """300 platforms on 1 Mbit/s, cadence on. Before the boot was paced (every platform's
    first heartbeat counted, members heartbeating only once their report was acknowledged,
    the roster broadcast unasked, retransmissions backing off from the swarm's channel
    time) the first master's heartbeats drowned in 299 members' 10 Hz heartbeats and
    reports, every member gave it up, and the swarm never formed (55 of 299 released).
    Before releases backed off the same way and members allowed for the channel's queue,
    the burst of a barrier of all made the first successor claim beside a live master."""
    scenario = Scenario(
        quiet_from=4.0,
        barrier_at=5.0,
        crash_at=8.0,
        end=10.0,
        channel_bitrate=1e6,
    )
    cell = run_cell("star", 300, 0.0, seed=1, scenario=scenario, cadence=True)
    assert cell.errors == [], cell.errors
    assert cell.formed_at_s < 4.0
    assert cell.all_released and cell.released == 300
    assert (cell.old_master, cell.new_master) == (1, 2)
    assert 0 < cell.failover_ms < 2000
    assert cell.run_false_leaves == 0
    # 300 members at 478 ms use half the channel, as asked.
    assert cell.member_cadence_ms == pytest.approx(478.4)
    assert 0.4 < (cell.channel_utilisation or 0.0) < 0.6
