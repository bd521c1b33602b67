"""Pictures of ``actorswarm bench table*``: our curves against the paper's points, versus
swarm size (log scale, so 5–30 and 100–1000 fit on one axis).

Six panels: Table II(a) and II(b) transition times, packets per second and packets per
switch at the master during II(a), Table III time to a new master, and Table I's single
Actor switch against the paper's boards (a bar chart). One line per mode and loss — and per
membership scheme when the report holds more than one (circles: star, squares: broadcast) —
(one plugin, or the smallest plugin count measured); markers are medians, bars span p95
down to the minimum; the paper's means are black triangles (Table III: its range as a band).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from actorswarm.bench import paper
from actorswarm.bench.tables import Table2Row, Table3Row, TablesReport, summarize

__all__ = ["plot_tables"]

_STYLE = {"sim": "-", "real": "--"}
_MARKER = {"star": "o", "broadcast": "s"}

#: A line's group: mode, membership scheme, loss.
_Key = tuple[str, str, float]


def _line(
    ax: Any,
    points: Sequence[tuple[int, Sequence[float]]],
    label: str,
    style: str,
    scale: float = 1.0,
    marker: str = "o",
) -> None:
    xs, med, lo, hi = [], [], [], []
    for size, values in sorted(points):
        s = summarize(values)
        if s.n == 0:
            continue
        xs.append(size)
        med.append(s.median * scale)
        lo.append((s.median - s.lo) * scale)
        hi.append((s.p95 - s.median) * scale)
    if xs:
        ax.errorbar(xs, med, yerr=[lo, hi], marker=marker, ls=style, capsize=3, label=label)


def _label(key: _Key, several: bool) -> str:
    """``mode, loss`` and, when the report holds several schemes, the row's scheme."""
    mode, scheme, loss = key
    return f"{mode}, {loss:.0%} loss" + (f", {scheme}" if several else "")


def _draw(
    ax: Any,
    groups: dict[_Key, list[Any]],
    value: Callable[[Any], Sequence[float]],
    several: bool,
) -> None:
    """One line per group: (size, ``value(row)``) of its rows."""
    for key, group in sorted(groups.items()):
        _line(
            ax,
            [(r.size, value(r)) for r in group],
            _label(key, several),
            _STYLE.get(key[0], "-"),
            marker=_MARKER.get(key[1], "o") if several else "o",
        )


def _several(rows: Sequence[Table2Row | Table3Row]) -> bool:
    return len({r.membership for r in rows}) > 1


def _groups(rows: Sequence[Table2Row], case: str) -> dict[_Key, list[Table2Row]]:
    """Rows of ``case`` by (mode, membership, loss), only the smallest plugin count."""
    out: dict[_Key, list[Table2Row]] = {}
    chosen = [r for r in rows if r.case == case]
    if not chosen:
        return out
    least = min(r.plugins for r in chosen)
    for r in chosen:
        if r.plugins == least:
            out.setdefault((r.mode, r.membership, r.loss), []).append(r)
    return out


def _panel2(
    ax: Any,
    rows: Sequence[Table2Row],
    case: str,
    value: Callable[[Table2Row], list[float]],
    paper_value: Callable[[paper.Paper2], float],
) -> None:
    _draw(ax, _groups(rows, case), value, _several(rows))
    refs = sorted(
        (size, paper_value(ref))
        for (c, size, plugins), ref in paper.TABLE2.items()
        if c == case and plugins == 1
    )
    ax.plot([s for s, _ in refs], [v for _, v in refs], "k^:", label="paper (1 plugin)")


def _panel3(ax: Any, rows: Sequence[Table3Row]) -> None:
    groups: dict[_Key, list[Table3Row]] = {}
    for r in rows:
        groups.setdefault((r.mode, r.membership, r.loss), []).append(r)
    _draw(ax, groups, lambda r: r.election_ms, _several(rows))
    lo, hi = paper.TABLE3_RANGE_MS
    ends = sorted(paper.TABLE3_ENDS)
    ax.fill_between(ends, [lo, lo], [hi, hi], color="grey", alpha=0.2, label="paper range")
    ax.plot(ends, [paper.TABLE3_ENDS[s] for s in ends], "k^:", label="paper (ends)")


def _panel1(ax: Any, report: TablesReport) -> None:
    """Table I: our switch times (median, bar to p99) against the paper's two boards."""
    labels, values, errors = [], [], []
    for row in report.table1:
        s = summarize(row.switch_ms)
        if s.n:
            labels.append(f"{row.mode}, {row.plugins}p\n{row.peers} peers")
            values.append(s.median)
            errors.append(s.p99 - s.median)
    for board in paper.TABLE1:
        labels.append(f"paper\n{board.board.replace(' ', chr(10))}")
        values.append(board.switch_ms)
        errors.append(0.0)
    colours = ["tab:blue"] * (len(labels) - len(paper.TABLE1)) + ["black"] * len(paper.TABLE1)
    ax.bar(range(len(labels)), values, yerr=errors, color=colours, capsize=3)
    ax.set_xticks(range(len(labels)), labels, fontsize="x-small")
    ax.set(
        yscale="log",
        ylabel="ms",
        title="Table I: single Actor switch (median, to p99)",
    )


def _size_labels(sizes: list[int]) -> list[str]:
    """A label for each size tick, blank where it would run into its neighbour on a log
    axis (25 next to 30); the largest sizes keep theirs."""
    labels: dict[int, str] = {}
    last = math.inf
    for size in sorted(sizes, reverse=True):
        close = math.log10(last / size) < 0.1
        labels[size] = "" if close else str(size)
        last = last if close else size
    return [labels[s] for s in sizes]


def plot_tables(report: TablesReport, out: Path) -> None:
    """Draw the report as one PNG at ``out`` (needs matplotlib)."""
    import matplotlib

    matplotlib.use("Agg")  # no display: files only
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    fig, axes = plt.subplots(2, 3, figsize=(18, 9), constrained_layout=True)
    several2 = _several(report.table2)
    (a, b, e), (c, f, d) = axes
    _panel2(a, report.table2, "switch", lambda r: r.transition_ms, lambda p: p.transition_ms)
    a.set(title="Table II(a): every platform switches (event → last)", ylabel="ms")
    _panel2(b, report.table2, "branch", lambda r: r.transition_ms, lambda p: p.transition_ms)
    b.set(title="Table II(b): two platforms branch (event → last)", ylabel="ms")
    _panel2(c, report.table2, "switch", lambda r: r.master_pps, lambda p: p.master_pps)
    c.set(title="Table II(a): packets/s at the master", ylabel="packets/s")
    _draw(f, _groups(report.table2, "switch"), lambda r: r.master_packets, several2)
    f.set(title="Table II(a): packets at the master per switch", ylabel="packets")
    _panel3(d, report.table3)
    d.set(title="Table III: master killed → new master acknowledged by all", ylabel="ms")
    paper_sizes = {size for _, size, _ in paper.TABLE2}
    sizes = sorted({r.size for r in report.table2} | {r.size for r in report.table3} | paper_sizes)
    for ax in (a, b, c, f, d):
        ax.set(xscale="log", xlabel="platforms")
        if ax is not d:
            ax.set_yscale("log")
        if sizes:
            ax.set_xticks(sizes, _size_labels(sizes))
        else:
            ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
        if ax is f:  # counts: plain numbers read better than powers of ten
            ax.yaxis.set_major_formatter(ScalarFormatter())
            ax.yaxis.set_minor_formatter(NullFormatter())
        handles, _ = ax.get_legend_handles_labels()
        if handles:
            ax.legend(fontsize="small")
        if not ax.has_data():
            ax.text(0.5, 0.5, "not measured", transform=ax.transAxes, ha="center")
    d.set_ylim(bottom=0)
    _panel1(e, report)
    fig.suptitle("actorswarm against the paper's Tables I–III (medians; bars: minimum to p95)")
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    plt.close(fig)
