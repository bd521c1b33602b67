"""Reporting of ``bench daemons``: the Markdown report of a :class:`BenchResult` — the
machine and settings, one table per measurement, then the rows of docs/design.md §8 these
measurements speak to, each with a plain verdict."""

from __future__ import annotations

import math
import statistics
from collections import Counter
from collections.abc import Callable, Sequence

from actorswarm.bench.daemons.results import SWITCH_TAIL, BenchResult, ResourceRun, SizeResult
from actorswarm.bench.daemons.stats import cpu_fit, finite, p95, scarce, verdict


def _ms(value: float) -> str:
    return "—" if math.isnan(value) else f"{value * 1000:.0f}"


def _summary(
    values: Sequence[float], show: Callable[[float], str], *, p95_too: bool = False
) -> str:
    """``median (min–max)`` of the finite ``values``, each shown by ``show`` (``median / p95
    (min–max)`` with ``p95_too``); "—" when there are none."""
    clean = finite(values)
    if not clean:
        return "—"
    middle = show(statistics.median(clean)) + (f" / {show(p95(clean))}" if p95_too else "")
    return f"{middle} ({show(min(clean))}–{show(max(clean))})"


def _ms_stats(values: Sequence[float]) -> str:
    """``median / p95 (min–max)`` in ms."""
    return _summary(values, _ms, p95_too=True)


def _range(values: Sequence[float], digits: int) -> str:
    return _summary(values, lambda v: f"{v:.{digits}f}")


def _cpu_per_switch(values: Sequence[float], size: int) -> str:
    """``median (min–max) (median per platform)`` in ms of CPU, or — when not measured."""
    clean = finite(values)
    if not clean:
        return "—"
    per_platform = statistics.median(clean) / size * 1e3
    return f"{_summary(clean, lambda v: f'{v * 1e3:.0f}')} ({per_platform:.1f})"


def _failed_failovers(size: SizeResult) -> int:
    """The failovers of ``size`` that went wrong or that not every survivor followed."""
    return sum(1 for f in size.failover if f.error or math.isnan(f.to_all_s))


def _failed_switches(size: SizeResult) -> int:
    return sum(1 for w in size.switch if w.error)


def _wakes(res: ResourceRun) -> str:
    """The members' median and the master's wakes per second ("—" when not measured)."""
    members, master = finite(res.sleeps_of("members")), res.sleeps_of("master")
    if not members:
        return "—"
    median = f"{statistics.median(members):.0f}"
    return f"{median} / {master[0]:.0f}" if master else f"{median} / –"


def markdown(result: BenchResult) -> str:
    """The report: machine, settings, one table per measurement, then docs/design.md §8."""
    m, s, c = result.machine, result.settings, result.config
    t_leave = c["t_leave"]
    lines = [
        "# Real daemons on one machine (`actorswarm bench daemons`)",
        "",
        f"Command: `{result.command or 'actorswarm bench daemons'}`, started {result.started}, "
        f"{result.wall_s / 60:.1f} min in all.",
        "",
        f"Machine: {m['cpu_model']}, {m['cpus']} CPU(s), {m['memory_gib']} GiB, {m['os']}; "
        f"Python {m['python']}, eclipse-zenoh {m['zenoh']}; actorswarm {m['actorswarm']}"
        + (f"; **the daemons ran actorswarm {m['daemons']}**." if m.get("daemons") else "."),
        "",
        "Every daemon is a separate `actorswarm daemon` process on 127.0.0.1 (Zenoh peer mode, "
        + (
            "TCP, a full mesh of listed endpoints, no multicast, "
            if s.get("broadcast", "mesh") == "mesh"
            else f"everything on Zenoh's UDP multicast transport, group {s['group']} on "
            f"{s['interface']}, "
        )
        + "HMAC on every packet), "
        f"heartbeat {c['heartbeat_interval'] * 1000:.0f} ms, "
        f"T_leave {t_leave * 1000:.0f} ms. **All of them, the ground station and the bench "
        f"share the machine's {m['cpus']} CPU(s)**: at the larger sizes the machine is loaded "
        "(see the load average column), so these are figures of a crowded host, not of one "
        "robot's computer.",
        "",
        f"Settings: CPU window {s['window']:.0f} s, {s['failovers']} failovers and "
        f"{s['switches']} switches per size, timeout {s['run_timeout']:.0f} s per run; "
        "Zenoh session lease "
        + (f"{s['lease']:g} s." if s.get("lease") else "the daemons' default."),
        "",
        "## CPU and memory per daemon",
        "",
        "A swarm of N daemons: each has N − 1 peers (the *peers* column is what each view "
        "held at the end of the window). *idle*: no script, only heartbeats and membership; "
        "*script*: actor A running (one `core.idle` plugin at 10 Hz), ground station connected. "
        "CPU is `utime + stime` of every thread of the process over the window, in % of one "
        "core, of the members (every daemon but the master; median (min–max)) and of the "
        "master apart; RSS is `VmRSS` (private part `RssAnon`) at its end, median (min–max) "
        "over all the daemons. *wire/s*: packets `lo` received per second (the network namespace's "
        "loopback: run the bench in a namespace of its own to count the swarm alone); *sent/s*: "
        "packets the daemons sent per second (a broadcast counts once; each daemon's rate "
        "over its own counters, which it writes every 10 s: a shorter window waits for them); "
        "their ratio is the "
        "packets on the wire per packet sent. *wakes/s*: how often a second the daemon's main "
        "thread went to sleep (its voluntary context switches: the loop's waits), members' "
        "median / the master's.",
        "",
        "| N | phase | peers | member CPU % of a core | master CPU % | wakes/s | RSS MiB "
        "| private MiB | all daemons, % of a core | load avg (1 min) | wire/s | sent/s "
        "| wire per sent |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        for res in r.resources:
            peers = sorted(set(res.peers))
            master = res.cpu_of("master")
            lines.append(
                f"| {r.size} | {res.phase} | {', '.join(map(str, peers))} "
                f"| {_range(res.cpu_of('members'), 2)} "
                f"| {f'{master[0]:.2f} (platform {res.master})' if master else '–'} "
                f"| {_wakes(res)} "
                f"| {_range(res.rss_mib, 1)} "
                f"| {_range(res.rss_anon_mib, 1)} | {sum(res.cpu_pct):.0f} "
                f"| {res.loadavg_1min:.1f} | {res.wire_packets_s:.0f} "
                f"| {res.sent_packets_s:.0f} "
                f"| {_ratio(res.wire_packets_s, res.sent_packets_s)} |"
            )
    capacity = 100.0 * max(1, int(m["cpus"]))
    crowded = [
        f"N={r.size} ({res.phase}: {sum(res.cpu_pct):.0f} %)"
        for r in result.sizes
        for res in r.resources
        if scarce(res, int(m["cpus"]))
    ]
    if crowded:
        lines += [
            "",
            f"**CPU was scarce** at {', '.join(crowded)} of the {capacity:.0f} % the machine "
            "has: there the per-daemon figure is what each daemon got, and less than it would "
            "use on a computer of its own.",
        ]
    lines += [
        "",
        "## Master failover",
        "",
        "SIGKILL to the agreed master's daemon; times from the bench's clock just before the "
        "signal. *claim*: the new master's own `master` log line; *all follow*: the last "
        "survivor's line naming the new master. median / p95 (min–max), ms; p95 by nearest "
        "rank, which is the worst run when there are fewer than 20.",
        "",
        "*Took it back*: runs after which the killed platform, restarted, became master "
        "again (a second change of master the swarm went through; see below).",
        "",
        "| N | runs | failed | masters killed | claim, ms | all follow, ms | took it back |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        failed = _failed_failovers(r)
        killed = ", ".join(str(f.killed) for f in r.failover)
        back = sum(1 for f in r.failover if f.master_after_restart == f.killed)
        lines.append(
            f"| {r.size} | {len(r.failover)} | {failed} | {killed} "
            f"| {_ms_stats([f.to_claim_s for f in r.failover])} "
            f"| {_ms_stats([f.to_all_s for f in r.failover])} | {back} of {len(r.failover)} |"
        )
    back_runs = [
        (r.size, f) for r in result.sizes for f in r.failover if f.master_after_restart == f.killed
    ]
    if back_runs:
        lines += [
            "",
            f"In {len(back_runs)} run(s) the restarted platform took the master role back "
            "although election is sticky (docs/design.md §3.2). Its log shows how: it names "
            "itself master within a second of starting, before its Zenoh links to the others "
            "are up; when they come up the two masters meet and the lower ID keeps the role, "
            "so the swarm changes master a second time, seconds after the restart.",
        ]
    lines += [
        "",
        "## Collective switch",
        "",
        "The ground station (in the bench process) sends the event to every platform; each "
        "platform's engine asks the master for the barrier, the master releases all with one "
        "message. *last*: send → the latest platform's transition (the switch time); *first*: "
        "send → the earliest; *spread*: first → last platform. median / p95 (min–max), ms. "
        "*Swarm CPU*: what every daemon together spent on the switch, from the send to "
        f"{SWITCH_TAIL * 1000:.0f} ms after the last platform switched, less its idle rate "
        "measured in the half second before (per platform in brackets; only the daemons "
        "that ran through all of it, so a restarted one does not count); divided by the "
        "machine's cores, about the least time the switch can take when every daemon shares "
        "them (less the part spent after the last platform switched).",
        "",
        "| N | runs | failed | last (switch time), ms | first, ms | spread, ms "
        "| swarm CPU, ms (per platform) | causes |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result.sizes:
        failed = _failed_switches(r)
        causes: Counter[str] = Counter()
        for w in r.switch:
            causes.update(w.causes)
        lines.append(
            f"| {r.size} | {len(r.switch)} | {failed} "
            f"| {_ms_stats([w.last_s for w in r.switch])} "
            f"| {_ms_stats([w.first_s for w in r.switch])} "
            f"| {_ms_stats([w.spread_s for w in r.switch])} "
            f"| {_cpu_per_switch([w.cpu_s for w in r.switch], r.size)} "
            f"| {', '.join(f'{k} {v}' for k, v in sorted(causes.items())) or '—'} |"
        )
    lines += ["", *_against_design(result), ""]
    problems = [f"- N={r.size}: {e}" for r in result.sizes for e in r.errors]
    problems += [
        f"- N={r.size}: failover of platform {f.killed}: {f.error}"
        for r in result.sizes
        for f in r.failover
        if f.error
    ]
    problems += [
        f"- N={r.size}: switch {w.src} → {w.dst}: {w.error}"
        for r in result.sizes
        for w in r.switch
        if w.error
    ]
    lines += ["## Problems during the run", ""]
    lines += problems or ["None: every run completed."]
    return "\n".join(lines) + "\n"


def _ratio(wire: float, sent: float) -> str:
    return f"{wire / sent:.1f}" if sent > 0 and not math.isnan(wire) else "–"


def _against_design(result: BenchResult) -> list[str]:
    """The rows of docs/design.md §8 these measurements speak to, with a plain verdict."""
    t_leave = result.config["t_leave"]
    cpus = int(result.machine.get("cpus") or 1)
    failover_target = t_leave + 0.1
    switch_target = 0.005  # 3 x loopback's one-way latency (microseconds) + 5 ms
    biggest = max(result.sizes, key=lambda r: r.size, default=None)
    lines = [
        "## Against docs/design.md §8",
        "",
        "| measure | paper | target | measured | met? |",
        "|---|---|---|---|---|",
    ]
    if biggest is None:
        return lines
    # The largest swarm, and the largest that settled when that one did not: a swarm that
    # never agreed says what the daemons cost while trying, not what a working one costs.
    shown = [biggest]
    settled = [r for r in result.sizes if not math.isnan(r.boot_s)]
    if math.isnan(biggest.boot_s) and settled:
        shown.insert(0, max(settled, key=lambda r: r.size))
    rows = [(r.size, res) for r in shown for res in r.resources]
    for n, res in rows:
        crowded = " (CPU scarce: what it got)" if scarce(res, cpus) else ""
        members = res.cpu_of("members")
        lines.append(
            f"| CPU per member, {res.phase}, N={n} ({n - 1} peers) | 0.25–1.1 % | ≤ 1 % of a "
            f"core at 30 peers | median {statistics.median(members):.2f} %, max "
            f"{max(members):.2f} %{crowded} | {verdict(members, 1.0, 0)} |"
        )
        master = res.cpu_of("master")
        lines.append(
            f"| CPU of the master, {res.phase}, N={n} | 0.25–1.1 % | ≤ 3 % of a core at 30 "
            "peers | "
            + (
                f"{master[0]:.2f} %{crowded} | {verdict(master, 3.0, 0)} |"
                if master
                else "no agreed master at the window's end | **no** |"
            )
        )
        megabytes = [v * 2**20 / 1e6 for v in res.rss_mib]
        lines.append(
            f"| RSS per daemon, {res.phase}, N={n} | 26–32 MB | ≤ 40 MB | median "
            f"{statistics.median(megabytes):.1f} MB, max {max(megabytes):.1f} MB "
            f"| {verdict(megabytes, 40.0, 0)} |"
        )
    fit = cpu_fit(result)
    if fit is not None:
        a, b, used = fit
        at30 = a + b * 30
        lines.append(
            f"| CPU per daemon at idle, extrapolated to 30 peers from N="
            f"{', '.join(map(str, used))} | 0.25–1.1 % | ≤ 1 % of a core | {a:.2f} % + "
            f"{b:.2f} % per peer → {at30:.1f} % | {'yes' if at30 <= 1.0 else '**no**'} |"
        )
    for r in result.sizes:
        values = [f.to_all_s for f in r.failover]
        lines.append(
            f"| new master after master failure, N={r.size} (all follow) | 382–909 ms "
            f"| ≤ T_leave + 100 ms = {failover_target * 1000:.0f} ms, flat in N "
            f"| {_ms_stats(values)} | {verdict(values, failover_target, _failed_failovers(r))} |"
        )
    for r in result.sizes:
        values = [w.last_s for w in r.switch]
        lines.append(
            f"| collective switch, N={r.size} | 1332 ms (30 platforms) | ≤ 3 × one-way "
            f"latency + 5 ms ≈ {switch_target * 1000:.0f} ms on loopback | {_ms_stats(values)} "
            f"| {verdict(values, switch_target, _failed_switches(r))} |"
        )
    largest = max((r.size for r in settled), default=0)
    unsettled = [r.size for r in result.sizes if math.isnan(r.boot_s)]
    measured = f"largest swarm that settled: {largest or 'none'}"
    if unsettled:
        measured += f"; never settled: N={', '.join(map(str, unsettled))}"
    lines.append(
        f"| real processes on one host | 10 in field | 50 | {measured} | "
        + ("yes" if largest >= 50 else "**no** (not at 50)")
        + " |"
    )
    medians = [
        (r.size, statistics.median(v))
        for r in result.sizes
        if (v := finite([f.to_all_s for f in r.failover]))
    ]
    if len(medians) >= 2:
        (n0, lo), (n1, hi) = medians[0], medians[-1]
        lines += [
            "",
            f"Failover in swarm size: median {_ms(lo)} ms at N={n0}, {_ms(hi)} ms at N={n1} "
            f"({(hi - lo) * 1000:+.0f} ms).",
        ]
    return lines
