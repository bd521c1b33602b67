"""The Markdown report of ``actorswarm bench table*``: ours next to the paper's, with ratios.

Each cell is ``median (p95; min–max)`` over the repetitions that succeeded; ``k/n`` says
how many did. The ratio is our median over the paper's mean (below 1: we are faster or
lighter). A paper column is empty where the paper has no figure (sizes beyond 30, lossy
rows, Table III between its two ends).

Tables II and III name the collective core's membership scheme each row ran with: in a
column when the report holds rows of more than one scheme (``--membership both``, or runs
of different schemes merged), otherwise once, above the tables.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from actorswarm.bench import paper
from actorswarm.bench.tables import (
    Summary,
    Table1Row,
    Table2Row,
    Table3Row,
    TablesReport,
    summarize,
)

__all__ = ["markdown", "problems"]


def _num(value: float, digits: int = 0) -> str:
    return "—" if math.isnan(value) else f"{value:,.{digits}f}"


def _cell(s: Summary, digits: int = 0) -> str:
    if s.n == 0:
        return "—"
    spread = f"{_num(s.lo, digits)}–{_num(s.hi, digits)}"
    return f"{_num(s.median, digits)} ({_num(s.p95, digits)}; {spread})"


def _ok(values: Sequence[float]) -> str:
    s = summarize(values)
    return f"{s.n}/{s.n + s.failed}"


def _ratio(ours: float, theirs: float | None) -> str:
    if theirs is None or math.isnan(ours) or theirs == 0:
        return ""
    return f"{ours / theirs:.3g}"


def _loss(loss: float) -> str:
    return f"{loss:.0%}"


def _table1(rows: Sequence[Table1Row]) -> list[str]:
    odroid, tx2 = paper.TABLE1
    lines = [
        "## Table I — one platform's overhead and the single Actor switch",
        "",
        "Two actors alternate at 1 Hz on every platform. **real**: one daemon of a swarm of "
        "peers + 1 daemons on this machine — CPU % of one core (every thread) over each "
        "window, resident memory at its end, and every switch it made (the switch call to "
        "the end of the new actor's first OODA step). **sim**: the simulator's CPU time per "
        "platform per simulated second (an upper bound of the protocol and runtime's cost, "
        "the simulated radio included, Zenoh not); one process hosts every platform, so no "
        "memory figure.",
        "",
        f"Paper: {odroid.board} {odroid.cpu_pct} % CPU, {odroid.memory_mb} MB, "
        f"{odroid.switch_ms:g} ms; {tx2.board} {tx2.cpu_pct} % CPU, {tx2.memory_mb} MB, "
        f"{tx2.switch_ms:g} ms. Ratios against the TX2 (the board of Table II).",
        "",
        "| mode | plugins | peers | CPU % of a core | ratio | RSS MiB | ratio "
        "| switch ms: median (p95; range) | p99 | switches | ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        cpu, rss, sw = summarize(r.cpu_pct), summarize(r.rss_mib), summarize(r.switch_ms)
        lines.append(
            f"| {r.mode} | {r.plugins} | {r.peers} | {_cell(cpu, 2)} | "
            f"{_ratio(cpu.median, tx2.cpu_pct)} | {_cell(rss, 1)} | "
            f"{_ratio(rss.median * 1.048576, tx2.memory_mb)} | {_cell(sw, 3)} | "
            f"{_num(sw.p99, 3)} | {sw.n} | {_ratio(sw.median, tx2.switch_ms)} |"
        )
    return lines


#: What each membership scheme is, for the report's header.
SCHEMES = {
    "star": "members heartbeat to the master only, the master broadcasts",
    "broadcast": "every platform heartbeats to every other, the paper's scheme",
}


def _schemes(report: TablesReport) -> list[str]:
    """The membership schemes of the report's Table II and III rows, sorted."""
    rows: list[Table2Row | Table3Row] = [*report.table2, *report.table3]
    return sorted({r.membership for r in rows})


def _table2(rows: Sequence[Table2Row], case: str, *, schemes: bool = False) -> list[str]:
    """Table II(a) or II(b); ``schemes`` adds the membership column after the mode."""
    title = (
        "## Table II(a) — every platform switches on one barrier"
        if case == "switch"
        else "## Table II(b) — two randomly chosen platforms branch together"
    )
    lines = [
        title,
        "",
        "Transition: the ground station sends the event → the last platform switched. "
        "Traffic: packets sent + received per second during the transition (heartbeats "
        "included) at the master and, averaged, at the non-masters; the packet counts behind "
        "them; bytes per packet on the wire (paper: about "
        f"{paper.BYTES_PER_PACKET} B). Paper figures are the mean of ten runs on TX2 boards.",
        "",
        f"| mode |{' membership |' if schemes else ''} N | plugins | loss | runs ok "
        "| transition ms: median (p95; range) | paper ms "
        "| ratio | master pkt/s | paper | non-master pkt/s | paper | master pkts "
        "| non-master pkts | bytes/pkt |",
        "|---" * (16 if schemes else 15) + "|",
    ]
    for r in rows:
        if r.case != case:
            continue
        ref = paper.table2(case, r.size, r.plugins) if r.loss == 0 else None
        t = summarize(r.transition_ms)
        master, member = summarize(r.master_pps), summarize(r.member_pps)
        scheme = f" {r.membership} |" if schemes else ""
        lines.append(
            f"| {r.mode} |{scheme} {r.size} | {r.plugins} | {_loss(r.loss)} "
            f"| {_ok(r.transition_ms)} | {_cell(t, 1)} | {_num(ref.transition_ms) if ref else ''} "
            f"| {_ratio(t.median, ref.transition_ms if ref else None)} "
            f"| {_num(master.median)} | {_num(ref.master_pps) if ref else ''} "
            f"| {_num(member.median)} | {_num(ref.member_pps) if ref else ''} "
            f"| {_num(summarize(r.master_packets).median)} "
            f"| {_num(summarize(r.member_packets).median, 1)} "
            f"| {_num(summarize(r.bytes_per_packet).median, 1)} |"
        )
    return lines


def _table3(rows: Sequence[Table3Row], *, schemes: bool = False) -> list[str]:
    """Table III; ``schemes`` adds the membership column after the mode."""
    lo, hi = paper.TABLE3_RANGE_MS
    lines = [
        "## Table III — the master's daemon killed → a new master acknowledged by all",
        "",
        f"Paper: {lo:g}–{hi:g} ms, growing with the swarm size (the text gives the range; "
        "we compare 5 with its low end and 30 with its high end).",
        "",
        f"| mode |{' membership |' if schemes else ''} N | loss | runs ok "
        "| new master ms: median (p95; range) | paper ms | ratio |",
        "|---" * (8 if schemes else 7) + "|",
    ]
    for r in rows:
        ref = paper.TABLE3_ENDS.get(r.size) if r.loss == 0 else None
        s = summarize(r.election_ms)
        scheme = f" {r.membership} |" if schemes else ""
        lines.append(
            f"| {r.mode} |{scheme} {r.size} | {_loss(r.loss)} | {_ok(r.election_ms)} | {_cell(s)} "
            f"| {_num(ref) if ref else ''} | {_ratio(s.median, ref)} |"
        )
    return lines


def problems(report: TablesReport) -> list[str]:
    """Every error a row recorded, prefixed with the row (and its membership scheme when the
    report holds more than one): what did not work in the run."""
    out: list[str] = [f"the run was cut short: {report.cut_short}"] if report.cut_short else []
    several = len(_schemes(report)) > 1

    def scheme(row: Table2Row | Table3Row) -> str:
        return f" membership={row.membership}" if several else ""

    rows: list[tuple[str, Sequence[str]]] = []
    rows += [(f"I {r.mode} plugins={r.plugins}", r.errors) for r in report.table1]
    rows += [
        (
            f"II {r.case} {r.mode}{scheme(r)} N={r.size} plugins={r.plugins} loss={_loss(r.loss)}",
            r.errors,
        )
        for r in report.table2
    ]
    rows += [
        (f"III {r.mode}{scheme(r)} N={r.size} loss={_loss(r.loss)}", r.errors)
        for r in report.table3
    ]
    for label, errors in rows:
        out += [f"{label}: {e}" for e in errors]
    return out


def _key(value: object) -> str:
    return str(value).replace("|", "/")


def markdown(report: TablesReport, *, title: str = "Benchmarks: the paper's Tables I–III") -> str:
    """The whole report: header (command, machine, radio model), one section per table
    present, and what went wrong."""
    # The membership scheme last: the rows of one cell in either scheme are neighbours.
    sort2: Callable[[Table2Row], tuple[object, ...]] = lambda r: (  # noqa: E731
        r.mode,
        r.loss,
        r.size,
        r.plugins,
        r.membership,
    )
    lines = [
        f"# {title}",
        "",
        f"Command: `{report.command}`",
        "",
        f"Started {report.started}, took {report.wall_s:.0f} s. Machine: "
        + ", ".join(f"{k} {_key(v)}" for k, v in report.machine.items())
        + ".",
        "",
        "Simulated rows (`sim`) run in virtual time over the simulated radio: "
        + ", ".join(f"{k.replace('_', ' ')} {_key(v)}" for k, v in report.radio.items())
        + ". Real rows (`real`) are `actorswarm daemon` processes over Zenoh on this "
        "machine's loopback, packets authenticated, every daemon sharing its cores.",
        "",
    ]
    schemes = _schemes(report)
    several = len(schemes) > 1
    if len(schemes) == 1:
        (scheme,) = schemes
        lines += [
            f"Tables II and III ran with the `{scheme}` membership scheme "
            f"({SCHEMES.get(scheme, 'as the core defines it')}).",
            "",
        ]
    if report.cut_short:
        lines += [f"**Not a complete run** ({report.cut_short}): only the rows below.", ""]
    if report.table1:
        lines += [*_table1(report.table1), ""]
    for case in ("switch", "branch"):
        rows = sorted((r for r in report.table2 if r.case == case), key=sort2)
        if rows:
            lines += [*_table2(rows, case, schemes=several), ""]
    if report.table3:
        rows3 = sorted(report.table3, key=lambda r: (r.mode, r.loss, r.size, r.membership))
        lines += [*_table3(rows3, schemes=several), ""]
    issues = problems(report)
    lines += ["## What did not work", ""]
    lines += [f"- {p}" for p in issues] if issues else ["Every repetition completed."]
    return "\n".join(lines) + "\n"
