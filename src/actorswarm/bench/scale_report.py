"""``actorswarm bench scale``'s report: the Markdown tables and the picture of a
:class:`~actorswarm.bench.scale.ScaleReport` (the figures are taken in
:mod:`actorswarm.bench.scale`)."""

from __future__ import annotations

import math
from pathlib import Path

from actorswarm.bench.scale import (
    SCHEMES,
    ScaleCell,
    ScaleReport,
    bitrate_text,
    cadence_text,
    protocol,
)

__all__ = ["markdown", "plot_scale", "problems"]


def _num(value: float, digits: int = 0) -> str:
    return "—" if math.isnan(value) else f"{value:,.{digits}f}"


def _rate(value: float) -> str:
    """A rate with the digits that matter: 3 significant ones below 100, none above."""
    if math.isnan(value):
        return "—"
    if value >= 100:
        return f"{value:,.0f}"
    return f"{value:.3g}"


def _wall(cell: ScaleCell) -> str:
    text = _rate(cell.wall_s)
    return f"{text} (over budget at {cell.reached_s:.1f} s)" if cell.over_budget else text


def _released(cell: ScaleCell) -> str:
    if not cell.expected:
        return "—"
    return "yes" if cell.all_released else f"no ({cell.released}/{cell.expected})"


def _formed(cell: ScaleCell) -> str:
    if not math.isnan(cell.formed_at_s):
        return f"{cell.formed_at_s:.2f}"
    return "—" if cell.over_budget else "no"


def _false_leaves(cell: ScaleCell) -> str:
    if math.isnan(cell.false_leaves_per_member_hour):
        return "—"
    return f"{cell.false_leaves_per_member_hour:.3g} ({cell.false_leaves})"


def _yes(flag: bool) -> str:
    return "yes" if flag else "no"


def _share(value: float) -> str:
    return "—" if math.isnan(value) else f"{value:.0%}"


def _channel_table(cells: list[ScaleCell], overhead: int) -> list[str]:
    """The second table: the channel and what the members' cadence costs, one row per cell
    in the order of the first; ``overhead``: the bytes the channel adds to each packet."""
    lines = [
        "| membership | N | loss | cadence | member heartbeat ms | heartbeat bits on air "
        "| sent pkt/s | carried pkt/s "
        "| carried kbit/s | channel busy | airtime drops: window (run) "
        "| longest wait ms: window (run) | master's leave timeout ms | member leave ms |",
        "|---" * 14 + "|",
    ]
    for c in cells:
        bits = (c.heartbeat_bytes + overhead) * 8
        lines.append(
            f"| {c.membership} | {c.size} | {c.loss:.0%} | {_yes(c.cadence)} "
            f"| {_num(c.member_cadence_ms)} | {_num(bits)} "
            f"| {_rate(c.air_pps)} | {_rate(c.channel_pps)} "
            f"| {_num(c.channel_kbps, 1)} | {_share(c.channel_utilisation)} "
            f"| {c.airtime_drops:,} ({c.run_airtime_drops:,}) "
            f"| {_num(c.max_wait_ms)} ({_num(c.run_max_wait_ms)}) "
            f"| {_num(c.leave_timeout_ms)} | {_num(c.member_leave_ms)} |"
        )
    return lines


def _channel_notes(report: ScaleReport) -> list[str]:
    """How the second table's figures are taken."""
    s = report.scenario
    window = f"{s.quiet_from:g}–{s.barrier_at:g} s"
    return [
        f"- *member heartbeat ms*: the interval at which the master's members heartbeat at "
        f"{s.barrier_at:g} s (the cadence it asks for; 100 without cadence); *heartbeat bits "
        "on air*: the mean heartbeat sent in the window, sealed, with the overhead — what the "
        "core's `heartbeat_bits` estimates.",
        f"- *sent, carried*: over {window}, packets sent per second by every platform (as "
        "above) and those the channel carried, with their kbit/s counted with the overhead "
        "(`SimRadio.channel_stats`; without a channel, carried is sent and kbit/s has no "
        "overhead); *channel busy*: the share of the window the channel was occupied.",
        f"- *airtime drops*: packets never put on the air because they would have waited "
        f"more than {s.max_queue_s:g} s for the channel, each counted once however many "
        f"would have heard it, over {window} and (in parentheses) over the whole run; "
        "*longest wait*: the longest a carried packet waited for the channel, the same two "
        "ways (the radio keeps no distribution of the waits, so no median).",
        f"- *master's leave timeout*: how long a member may stay silent, at {s.barrier_at:g} s, "
        "before the master declares it gone (`Membership.silence`, probing included); "
        "*member leave*: the member crash → the master's `MemberLeft` of it, measured.",
    ]


def problems(report: ScaleReport) -> list[str]:
    """Every error a cell recorded, prefixed with the cell: what did not work in the run."""
    out = [f"the run was cut short: {report.cut_short}"] if report.cut_short else []
    return out + [f"{c.label}: {e}" for c in report.cells for e in c.errors]


def markdown(report: ScaleReport) -> str:
    """The whole report: the command and the machine, the scenario, one table row per cell
    (sorted by loss, size, scheme), how each figure is taken, and what did not work."""
    s = report.scenario
    proto = protocol()
    lines = [
        "# Benchmark: what the swarm size costs (`actorswarm bench scale`)",
        "",
        f"Command: `{report.command}`",
        "",
        f"Started {report.started}, took {report.wall_s:.0f} s. Machine: "
        + ", ".join(f"{k} {str(v).replace('|', '/')}" for k, v in report.machine.items())
        + ".",
        "",
        f"Scenario, in virtual time, on a fresh swarm per row: N platforms boot at 0 s; "
        f"{s.quiet_from:g}–{s.barrier_at:g} s is the quiet steady state over which traffic and "
        f"false leaves are taken; at {s.barrier_at:g} s every platform requests one barrier of "
        f"the whole swarm; at {s.crash_at:g} s the master crashes; the run ends at "
        f"{s.end:g} s. Radio: one-way latency {s.latency * 1000:g} ms, no jitter, each packet "
        "lost independently per receiver at the row's rate. Protocol: heartbeat "
        f"{proto['heartbeat_ms']:g} ms, T_leave {proto['t_leave_ms']:g} ms, T_join "
        f"{proto['t_join_ms']:g} ms. Membership `star`: {SCHEMES['star']}; `broadcast`: "
        f"{SCHEMES['broadcast']}. A row is abandoned after {s.max_wall:g} s of wall time "
        "(over budget, with the virtual time it reached).",
        "",
    ]
    channel = s.channel_bitrate is not None
    if channel:
        lines += [
            f"Channel: every platform shares one radio channel of "
            f"{bitrate_text(s.channel_bitrate or 0)}, first come first served; a packet "
            f"occupies it for its bytes plus {s.overhead_bytes} bytes of overhead (the IPv4 and "
            f"UDP headers), and one that would wait more than {s.max_queue_s:g} s for it is "
            "dropped. Rows *with cadence* give the core that bitrate: a star master asks its "
            f"members to heartbeat so that they use at most {proto['heartbeat_share']:g} of it "
            f"({proto['heartbeat_bits']} bits per heartbeat); rows *without* heartbeat at "
            f"{1000 / proto['heartbeat_ms']:g} Hz whatever the channel.",
            "",
        ]
    if s.member_crash_at is not None:
        lines += [
            f"At {s.member_crash_at:g} s the member with the highest ID crashes: how long the "
            "master takes to declare it gone is measured.",
            "",
        ]
    if report.cut_short:
        lines += [f"**Not a complete run** ({report.cut_short}): only the rows below.", ""]
    # The cadence column only when there is a channel: without one every row has none.
    cadence_head = "| cadence " if channel else ""
    lines += [
        f"| membership | N | loss {cadence_head}| wall s | sim s / wall s | peak MiB "
        "| formed at, s | all released | failover ms | non-master rx pkt/s: median (min–max) "
        "| master rx pkt/s | on-air pkt/s | on-air kbit/s | false leaves / member-hour (count) |",
        "|---" * (15 if channel else 14) + "|",
    ]
    cells = sorted(report.cells, key=lambda c: (c.loss, c.size, c.membership, c.cadence))
    for c in cells:
        member = _rate(c.member_recv_pps)
        if not math.isnan(c.member_recv_pps):
            member += f" ({_rate(c.member_recv_pps_min)}–{_rate(c.member_recv_pps_max)})"
        cadence = f"| {_yes(c.cadence)} " if channel else ""
        lines.append(
            f"| {c.membership} | {c.size} | {c.loss:.0%} {cadence}| {_wall(c)} "
            f"| {c.sim_per_wall:.3g} | {_rate(c.peak_rss_mib)} | {_formed(c)} | {_released(c)} "
            f"| {_num(c.failover_ms)} | {member} | {_rate(c.master_recv_pps)} "
            f"| {_rate(c.air_pps)} | {_num(c.air_kbps, 1)} | {_false_leaves(c)} |"
        )
    if channel or s.member_crash_at is not None:
        # Without a channel nothing is added to a packet on the air.
        overhead = s.overhead_bytes if channel else 0
        lines += ["", *_channel_table(cells, overhead)]
    lines += [
        "",
        "How each figure is taken (`src/actorswarm/bench/scale.py`):",
        "",
        "- *wall s*: wall-clock time of the whole run, booting the swarm included; *sim s / "
        "wall s*: virtual seconds reached per wall-clock second; *peak MiB*: the bench "
        "process's peak resident memory over the run (`VmHWM`, reset before it), the "
        "interpreter's own included.",
        "- *formed at*: the first virtual time with one master that has every other platform "
        "in its view and its handshake done.",
        "- *all released*: every platform's `BarrierReleased` for the barrier of all, "
        f"before the run ended (the master crashes {s.crash_at - s.barrier_at:g} s after the "
        "request).",
        "- *failover*: the master crashes → the first new master that every survivor "
        "acknowledged: all of them in its view, each reported to it (looked at every 5 ms "
        "of virtual time).",
        f"- *rx pkt/s, on air*: the radio's counters over {s.quiet_from:g}–{s.barrier_at:g} s: "
        "packets delivered per second to each non-master (median, and the range over them) "
        "and to the master; packets and kbit sent per second by every platform, a broadcast "
        "counted once (bytes as encoded, without radio framing).",
        "- *false leaves*: the master's `MemberLeft` of a platform that was alive, over the "
        "same window, per member-hour (N − 1 members watched for the window), the count in "
        "parentheses. The JSON adds the master's joins in the window and the false leaves "
        "over the whole run.",
    ]
    if channel or s.member_crash_at is not None:
        lines += _channel_notes(report)
    lines += [
        "",
        "## What did not work",
        "",
    ]
    issues = problems(report)
    lines += [f"- {p}" for p in issues] if issues else ["Every row ran to its end and worked."]
    return "\n".join(lines) + "\n"


# --- picture -------------------------------------------------------------------------------

_COLOUR = {"star": "tab:blue", "broadcast": "tab:orange"}
#: With a channel, the rows with cadence in colours of their own.
_CADENCE_COLOUR = {"star": "tab:green", "broadcast": "tab:red"}


def plot_scale(report: ScaleReport, out: Path) -> None:
    """Draw the report as one PNG at ``out``: packets received per second against N
    (log-log; non-masters: the median, bars to the min and max; the master), and wall time
    against N (an over-budget row: a cross at the time it was abandoned). One line per
    scheme, loss and cadence. With a channel, a third panel: the packets sent and carried
    per second against N."""
    import matplotlib

    matplotlib.use("Agg")  # no display: files only
    import matplotlib.pyplot as plt
    from matplotlib.axes import Axes
    from matplotlib.ticker import NullFormatter

    channel = report.scenario.channel_bitrate is not None
    fig, panels = plt.subplots(
        1, 3 if channel else 2, figsize=(19 if channel else 13, 5), constrained_layout=True
    )
    rx, wall = panels[0], panels[1]
    air: Axes | None = panels[2] if channel else None
    several = len({c.loss for c in report.cells}) > 1
    groups: dict[tuple[str, float, bool], list[ScaleCell]] = {}
    for c in sorted(report.cells, key=lambda c: c.size):
        groups.setdefault((c.membership, c.loss, c.cadence), []).append(c)
    for (scheme, loss, cadence), cells in sorted(groups.items()):
        colour = (_CADENCE_COLOUR if cadence else _COLOUR).get(scheme)
        name = scheme + (f", {loss:.0%} loss" if several else "")
        name += f", {cadence_text(cadence)}" if channel else ""
        style = "-" if loss == min(k[1] for k in groups) else ":"
        # Non-positive values cannot sit on a log axis: they are left out.
        members = [c for c in cells if c.member_recv_pps > 0]
        if members:
            med = [c.member_recv_pps for c in members]
            rx.errorbar(
                [c.size for c in members],
                med,
                yerr=[
                    [m - c.member_recv_pps_min for m, c in zip(med, members, strict=True)],
                    [c.member_recv_pps_max - m for m, c in zip(med, members, strict=True)],
                ],
                marker="o",
                ls=style,
                color=colour,
                capsize=3,
                label=f"{name}: non-master (median)",
            )
        masters = [c for c in cells if c.master_recv_pps > 0]
        if masters:
            rx.plot(
                [c.size for c in masters],
                [c.master_recv_pps for c in masters],
                marker="s",
                ls="--" if style == "-" else "-.",
                color=colour,
                label=f"{name}: master",
            )
        timed = [c for c in cells if c.wall_s > 0]
        if timed:
            wall.plot(
                [c.size for c in timed],
                [c.wall_s for c in timed],
                marker="o",
                ls=style,
                color=colour,
                label=name,
            )
            over = [c for c in timed if c.over_budget]
            if over:
                wall.plot(
                    [c.size for c in over],
                    [c.wall_s for c in over],
                    "x",
                    color="red",
                    markersize=10,
                    label=f"{name}: over budget",
                )
        sent = [c for c in cells if c.air_pps > 0 and c.channel_pps > 0]
        if air is not None and sent:
            sizes = [c.size for c in sent]
            air.plot(sizes, [c.air_pps for c in sent], marker="o", ls=style, color=colour,
                     label=f"{name}: sent")  # fmt: skip
            air.plot(sizes, [c.channel_pps for c in sent], marker="^", ls="--", color=colour,
                     label=f"{name}: carried")  # fmt: skip
    rx.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="packets received / s",
        title=f"quiet steady state ({report.scenario.quiet_from:g}–"
        f"{report.scenario.barrier_at:g} s): packets received per second",
    )
    wall.set(
        xscale="log",
        yscale="log",
        xlabel="platforms",
        ylabel="wall s",
        title=f"wall time of the whole {report.scenario.end:g} s run",
    )
    if air is not None:
        air.set(
            xscale="log",
            yscale="log",
            xlabel="platforms",
            ylabel="packets / s",
            title=f"the {bitrate_text(report.scenario.channel_bitrate or 0)} channel "
            f"({report.scenario.quiet_from:g}–{report.scenario.barrier_at:g} s): "
            "packets sent and carried per second",
        )
    sizes = sorted({c.size for c in report.cells})
    for ax in (rx, wall) if air is None else (rx, wall, air):
        if sizes:  # the sizes measured, in plain numbers
            ax.set_xticks(sizes, [str(n) for n in sizes])
            ax.xaxis.set_minor_formatter(NullFormatter())
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize="small")
        else:
            ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center")
    fig.suptitle(
        "actorswarm: what the swarm size costs on a shared channel, with and without cadence"
        if channel
        else "actorswarm: what the swarm size costs, star against broadcast membership"
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
