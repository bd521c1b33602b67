"""What a ``task verify`` says: the terminal summary, the JSON report and the report
directory (an HTML page with its plots, and each failure class's recording).

The figures: the completion rate with its 95 % Wilson interval; completion times p50, p95
and max over the runs that completed; the closest approach of any two airborne vehicles
(and its margin over the minimum they had to keep) p5, p50 and min; and the failure
classes, largest first, each with its smallest failing schedule and the one ``actorswarm
sim`` command that replays it.
"""

from __future__ import annotations

import html
import json
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from actorswarm.sim.verify.session import Outcome

__all__ = ["as_json", "quantile", "summary_lines", "write_report_dir"]


def quantile(values: Sequence[float], q: float) -> float | None:
    """The ``q`` quantile of ``values`` (linear between the order statistics); None when
    there are none."""
    if not values:
        return None
    ordered = sorted(values)
    pos = q * (len(ordered) - 1)
    low = int(pos)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (pos - low)


def _figures(outcome: Outcome) -> dict[str, Any]:
    results = outcome.results
    times = [r.completion_s for r in results if r.completion_s is not None]
    closest = [r.closest_m for r in results if r.closest_m is not None]
    margins = [m for r in results if (m := r.margin_m) is not None]
    low, high = outcome.completion_interval()
    n = len(results)
    return {
        "runs": n,
        "planned": outcome.planned,
        "completed": outcome.completed,
        "completion_rate": None if n == 0 else outcome.completed / n,
        "completion_ci95": [low, high],
        "completion_s": {
            "p50": quantile(times, 0.5),
            "p95": quantile(times, 0.95),
            "max": max(times, default=None),
        },
        "closest_m": {
            "min": min(closest, default=None),
            "p5": quantile(closest, 0.05),
            "p50": quantile(closest, 0.5),
        },
        "margin_m": {"min": min(margins, default=None), "p5": quantile(margins, 0.05)},
        "runs_with_violations": outcome.violations(),
        "master_changes": {"p50": quantile([r.master_changes for r in results], 0.5)},
        "failed": sum(1 for r in results if not r.ok),
        "wall_s": round(outcome.wall_s, 2),
        "runs_s": round(outcome.runs_s, 2),
        # The runs alone (minimizing and recording excluded): the throughput.
        "runs_per_s": None if outcome.runs_s <= 0 else round(n / outcome.runs_s, 3),
    }


def as_json(outcome: Outcome, *, require: float | None = None) -> dict[str, Any]:
    """The JSON report: the mission, the profile, the figures, the classes and every run."""
    m = outcome.mission
    return {
        "script": m.script_path,
        "world": None if m.no_world else m.world_path,
        "duration_s": m.duration,
        "events": [{"name": e.name, "t": e.t} for e in m.events],
        "seeds": [outcome.first_seed, outcome.first_seed + outcome.planned - 1],
        "profile": {"source": outcome.profile.source, **outcome.profile.as_dict()},
        "where": outcome.where,
        "interrupted": outcome.interrupted,
        "require": require,
        "figures": _figures(outcome),
        "classes": [c.as_dict() for c in outcome.classes],
        "results": [r.as_dict() for r in outcome.results],
    }


def _num(value: float | None, fmt: str = ".1f", unit: str = "") -> str:
    return "-" if value is None else f"{value:{fmt}}{unit}"


def summary_lines(outcome: Outcome) -> list[str]:
    """The terminal summary."""
    f = _figures(outcome)
    m = outcome.mission
    n = f["runs"]
    lines = [
        f"{m.script_path}: {n} run(s) of {m.duration:g} s, seeds {outcome.first_seed}.."
        f"{outcome.first_seed + outcome.planned - 1}, faults from {outcome.profile.source}"
        + (f" (interrupted after {n} of {outcome.planned})" if outcome.interrupted else ""),
    ]
    if n == 0:
        return [*lines, "no run finished"]
    low, high = f["completion_ci95"]
    lines.append(
        f"completed: {f['completed']}/{n} = {f['completion_rate']:.1%} "
        f"(95 % CI {low:.1%}–{high:.1%})"
    )
    t = f["completion_s"]
    lines.append(
        f"time to complete: p50 {_num(t['p50'], unit=' s')}, p95 {_num(t['p95'], unit=' s')}, "
        f"max {_num(t['max'], unit=' s')}"
    )
    c, g = f["closest_m"], f["margin_m"]
    if c["min"] is not None:
        lines.append(
            f"closest approach: min {_num(c['min'], '.2f', ' m')}, p5 "
            f"{_num(c['p5'], '.2f', ' m')}, p50 {_num(c['p50'], '.2f', ' m')} (margin over the "
            f"minimum: min {_num(g['min'], '+.2f', ' m')})"
        )
    lines.append(
        f"runs with an invariant violated, a separation breached or a crash: "
        f"{f['runs_with_violations']}; failed runs: {f['failed']} in {len(outcome.classes)} "
        "class(es)"
    )
    for i, cls in enumerate(outcome.classes, start=1):
        lines.append(f"class {i}: {len(cls.seeds)} run(s): {cls.signature}")
        mini = cls.minimized
        schedule = mini.schedule if mini is not None else cls.schedule
        if mini is not None:
            state = "" if mini.complete else ", re-run budget spent: may not be minimal"
            if mini.result.signature != cls.signature:
                state = ", did not fail again the same way: the unminimized schedule is given"
            lines.append(
                f"  smallest schedule: {len(mini.schedule.items)} of {mini.original} fault(s) "
                f"({mini.reruns} re-runs{state})"
            )
        for item in schedule.items:
            lines.append(f"    - {item.text}")
        if not schedule.items:
            lines.append("    - no fault at all: it fails on a clean radio with this seed")
        lines.append(f"  replay: {cls.replay}")
        if cls.recording:
            lines.append(f"  recording: {cls.recording}")
    rest = outcome.wall_s - outcome.runs_s
    lines.append(
        f"{n} runs in {outcome.runs_s:.1f} s ({f['runs_per_s'] or 0:.3f} runs/s) on "
        f"{outcome.where or 'this machine'}"
        + (f", then {rest:.1f} s minimizing and recording" if rest >= 0.05 else "")
    )
    return lines


def write_report_dir(outcome: Outcome, out: Path, recordings: dict[int, Path]) -> None:
    """Write ``index.html``, ``report.json`` and the plots into ``out``, whole or not at
    all: everything goes to a new directory beside it that takes ``out``'s place at the end
    (``recordings``: class index -> an MCAP file already written, moved in)."""
    out = out.resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        for i, path in recordings.items():
            name = f"class-{i}.mcap"
            shutil.move(str(path), staging / name)
            outcome.classes[i - 1].recording = str(out / name)
        (staging / "report.json").write_text(json.dumps(as_json(outcome), indent=2) + "\n")
        pictures = _plots(outcome, staging)
        (staging / "index.html").write_text(_page(outcome, pictures), encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        staging.rename(out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def _plots(outcome: Outcome, out: Path) -> list[tuple[str, str]]:
    """The PNGs of the report: ``(file name, caption)`` each."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    made: list[tuple[str, str]] = []

    def save(fig: Figure, name: str, caption: str) -> None:
        FigureCanvasAgg(fig)
        fig.tight_layout()
        fig.savefig(out / name, format="png", dpi=110)
        made.append((name, caption))

    results = outcome.results
    times = [r.completion_s for r in results if r.completion_s is not None]
    if times:
        fig = Figure(figsize=(6.4, 3.2))
        ax = fig.add_subplot()
        ax.hist(times, bins=min(30, max(5, len(times) // 4)), color="#4c72b0")
        ax.set_xlabel("time to complete (s)")
        ax.set_ylabel("runs")
        save(fig, "completion.png", f"Time to complete, {len(times)} completed runs")
    margins = [m for r in results if (m := r.margin_m) is not None]
    if margins:
        fig = Figure(figsize=(6.4, 3.2))
        ax = fig.add_subplot()
        ax.hist(margins, bins=min(30, max(5, len(margins) // 4)), color="#55a868")
        ax.axvline(0.0, color="#c44e52", linestyle="--", label="the minimum")
        ax.set_xlabel("closest approach − required separation (m)")
        ax.set_ylabel("runs")
        ax.legend()
        save(fig, "separation.png", "Separation margin per run (left of the line: a breach)")
    if outcome.classes:
        fig = Figure(figsize=(6.4, 0.6 + 0.45 * len(outcome.classes)))
        ax = fig.add_subplot()
        labels = [f"class {i}" for i in range(1, len(outcome.classes) + 1)]
        ax.barh(labels[::-1], [len(c.seeds) for c in outcome.classes][::-1], color="#c44e52")
        ax.set_xlabel("failed runs")
        save(fig, "classes.png", "Failed runs per failure class")
    return made


_STYLE = (
    "body{font-family:sans-serif;max-width:60em;margin:2em auto}"
    "pre{white-space:pre-wrap;background:#f4f4f4;padding:.5em}"
    "figure{display:inline-block;margin:.5em}"
)


def _page(outcome: Outcome, pictures: list[tuple[str, str]]) -> str:
    esc = html.escape
    lines = summary_lines(outcome)
    head: list[str] = []
    classes: list[str] = []
    for line in lines:
        (classes if classes or line.startswith("class ") else head).append(line)
    rows = []
    for i, cls in enumerate(outcome.classes, start=1):
        schedule = cls.minimized.schedule if cls.minimized else cls.schedule
        faults = "".join(f"<li>{esc(item.text)}</li>" for item in schedule.items) or (
            "<li>no fault at all</li>"
        )
        rec = (
            f'<p>Recording: <a href="class-{i}.mcap">class-{i}.mcap</a> (Foxglove, '
            "<code>actorswarm web --replay</code>)</p>"
            if cls.recording
            else ""
        )
        rows.append(
            f"<h3>Class {i}: {len(cls.seeds)} run(s)</h3><p><b>{esc(cls.signature)}</b></p>"
            f"<p>Seeds: {esc(', '.join(str(s) for s in cls.seeds[:40]))}"
            f"{' …' if len(cls.seeds) > 40 else ''}</p><p>Smallest failing schedule:</p>"
            f"<ul>{faults}</ul><p>Replay:</p><pre>{esc(cls.replay)}</pre>{rec}"
        )
    figures = "".join(
        f'<figure><img src="{esc(name)}" alt="{esc(caption)}"><figcaption>{esc(caption)}'
        "</figcaption></figure>"
        for name, caption in pictures
    )
    return (
        "<!doctype html><html><head><meta charset='utf-8'><title>task verify: "
        f"{esc(outcome.mission.script_path)}</title><style>{_STYLE}</style></head><body>"
        f"<h1>task verify: {esc(outcome.mission.script_path)}</h1>"
        f"<pre>{esc(chr(10).join(head))}</pre>{figures}<h2>Failure classes</h2>"
        + ("".join(rows) or "<p>None: every run completed with every invariant held.</p>")
        + "<p>Every run's result is in <a href='report.json'>report.json</a>.</p></body></html>"
    )
