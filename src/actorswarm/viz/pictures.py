"""PNG pictures of a recorded run (:class:`~actorswarm.sim.record.Recording`).

:func:`trajectory_png` draws the top view of every platform's path, coloured by the actor
the platform was running, with snapshots of the fleet at each collective transition (the
moments many platforms switched together, :func:`~actorswarm.sim.record.
collective_transitions`). :func:`timeline_png` draws how many platforms ran each actor
over time, with the same moments marked.

Drawing goes through matplotlib's Agg canvas on a private figure: files only, no window,
no pyplot state, so it works headless and from several threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon
from numpy.typing import NDArray

from actorswarm.sim.record import Collective, Recording, Span, actor_timeline
from actorswarm.sim.record import collective_transitions as find_collectives

__all__ = ["timeline_png", "trajectory_png"]

#: The label of the time a platform runs no actor.
NO_ACTOR = "(no actor)"
_DPI = 120


def _title(recording: Recording, what: str) -> str:
    """``what``, after the mission's name (a shipped mission: two share one script) or
    else the script's."""
    mission = recording.meta.get("mission")
    if isinstance(mission, str) and mission:
        return f"{mission} mission: {what}"
    name = recording.meta.get("script") or recording.meta.get("name")
    return f"{name}: {what}" if isinstance(name, str) and name else what


def _colours(labels: Sequence[str]) -> dict[str, tuple[float, float, float, float]]:
    """One colour per label, in order; grey for :data:`NO_ACTOR`."""
    cmap = colormaps["tab10" if len(labels) <= 10 else "tab20"]
    out: dict[str, tuple[float, float, float, float]] = {}
    i = 0
    for label in labels:
        if label == NO_ACTOR:
            out[label] = (0.6, 0.6, 0.6, 1.0)
            continue
        r, g, b, a = cmap(i % cmap.N)
        out[label] = (float(r), float(g), float(b), float(a))
        i += 1
    return out


def _running(spans: Sequence[Span], platform: int, t: float) -> str:
    """The label of what ``platform`` ran at ``t``: its actors joined with ``+``."""
    actors = sorted(
        actor
        for p, actor, start, end in spans
        if p == platform and start <= t and (end is None or t < end)
    )
    return "+".join(actors) if actors else NO_ACTOR


def _collectives(recording: Recording) -> list[Collective]:
    return find_collectives(recording.transitions, fleet=len(recording.platforms()) or None)


def _save(fig: Figure, out: Path) -> Path:
    FigureCanvasAgg(fig)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, format="png", dpi=_DPI)
    return out


def trajectory_png(recording: Recording, out: Path) -> Path:
    """Draw the top view of the run (x east, y north, metres) into the PNG ``out``.

    Each platform's path is drawn in segments coloured by the actor(s) it was running then
    (one colour per actor, in the legend; a segment is cut where the platform switched),
    with a circle where it started and a square where it ended; at each collective
    transition a small triangle marks every platform's position then, captioned with the
    transition's event and time.
    Returns ``out``.
    """
    spans = actor_timeline(recording.transitions)
    fig = Figure(figsize=(11.0, 7.5), layout="constrained")
    ax: Axes = fig.add_subplot()
    ax.set_title(_title(recording, "trajectories (top view)"))
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.grid(True, linewidth=0.4, alpha=0.5)

    paths: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    for platform in recording.platforms():
        times, xyz = recording.path(platform)
        if len(times):
            paths[platform] = (times, xyz)
    if not paths:
        ax.text(0.5, 0.5, "no poses recorded", ha="center", va="center", transform=ax.transAxes)
        return _save(fig, out)

    # Segments per label, labels in order of first appearance.
    segments: dict[str, list[NDArray[np.float64]]] = {}
    for platform, (times, xyz) in paths.items():
        # Break the path at this platform's switches, so each piece has one label.
        cuts = {
            t
            for p, _, start, end in spans
            if p == platform
            for t in (start, end)
            if t is not None and times[0] < t < times[-1]
        }
        at = np.union1d(times, np.fromiter(cuts, dtype=np.float64, count=len(cuts)))
        xy = np.stack([np.interp(at, times, xyz[:, 0]), np.interp(at, times, xyz[:, 1])], axis=1)
        for i in range(len(at) - 1):
            label = _running(spans, platform, float(at[i] + at[i + 1]) / 2)
            segments.setdefault(label, []).append(xy[i : i + 2])
        if len(at) == 1:
            segments.setdefault(_running(spans, platform, float(at[0])), [])
    order = sorted(segments, key=lambda lab: (lab == NO_ACTOR, _first_start(spans, lab)))
    colour = _colours(order)
    for label in order:
        if segments[label]:
            ax.add_collection(
                LineCollection(segments[label], colors=[colour[label]], linewidths=1.6, zorder=2)
            )

    _areas_and_targets(ax, recording)
    starts = np.array([xyz[0, :2] for _, xyz in paths.values()])
    ends = np.array([xyz[-1, :2] for _, xyz in paths.values()])
    ax.scatter(starts[:, 0], starts[:, 1], s=36, facecolors="white", edgecolors="black", zorder=4)
    ax.scatter(ends[:, 0], ends[:, 1], s=22, marker="s", color="black", zorder=5)
    if len(paths) <= 30:
        for platform, (_, xyz) in paths.items():
            ax.annotate(
                str(platform),
                (float(xyz[0, 0]), float(xyz[0, 1])),
                textcoords="offset points",
                xytext=(4, -9),
                fontsize=6,
                color="dimgray",
            )

    every_x = np.concatenate([xyz[:, 0] for _, xyz in paths.values()])
    mid_x = float(every_x.min() + every_x.max()) / 2
    snap_handles: list[Line2D] = []
    snap_colours = colormaps["Dark2"]
    captions: set[str] = set()
    for moment in _collectives(recording):
        # Parts of one release (a merge: C → D and B → D on one event) are one snapshot.
        caption = f"{moment.label} @ {moment.t:.1f} s"
        if caption in captions:
            continue
        captions.add(caption)
        k = len(captions) - 1
        at = np.array(
            [
                [np.interp(moment.t, times, xyz[:, 0]), np.interp(moment.t, times, xyz[:, 1])]
                for times, xyz in paths.values()
                if times[0] <= moment.t <= times[-1]
            ]
        )
        if not len(at):
            continue
        c = snap_colours(k % snap_colours.N)
        ax.scatter(at[:, 0], at[:, 1], s=30, marker="^", color=c, alpha=0.85, zorder=6)
        x = float(at[:, 0].mean())
        right = x > mid_x  # caption inwards, so it stays inside the axes
        ax.annotate(
            caption,
            (x, float(at[:, 1].max())),
            textcoords="offset points",
            xytext=(-6 if right else 6, 8 + 12 * (k % 3)),
            ha="right" if right else "left",
            fontsize=8,
            color=c,
            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": c, "alpha": 0.85},
            zorder=7,
        )
        snap_handles.append(
            Line2D([], [], marker="^", linestyle="", color=c, label=f"fleet at {caption}")
        )

    ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.margins(0.08)
    handles = [Line2D([], [], color=colour[label], linewidth=2, label=label) for label in order]
    handles += [
        Line2D(
            [], [], marker="o", linestyle="", markerfacecolor="white", color="black", label="start"
        ),
        Line2D([], [], marker="s", linestyle="", color="black", label="end"),
        *snap_handles,
    ]
    if recording.targets:
        handles.append(
            Line2D(
                [],
                [],
                marker="D",
                markerfacecolor="black",
                markeredgecolor="black",
                linestyle="--",
                linewidth=3.0,
                color="0.45",
                alpha=0.8,
                label="target route (end: ◆)",
            )
        )
    fig.legend(handles=handles, loc="outside right upper", fontsize=8, framealpha=0.9)
    return _save(fig, out)


def _areas_and_targets(ax: Axes, recording: Recording) -> None:
    """The world's areas (shaded outlines, named) and each target's path (a wide dashed
    grey band, a diamond where it ended), under the vehicles' paths."""
    for name, polygon in recording.areas().items():
        ax.add_patch(
            Polygon(polygon, closed=True, facecolor="0.9", edgecolor="0.6", linewidth=0.8, zorder=1)
        )
        x0, y0 = min(p[0] for p in polygon), max(p[1] for p in polygon)
        ax.annotate(
            f"area {name}",
            (x0, y0),
            textcoords="offset points",
            xytext=(3, -10),
            fontsize=7,
            color="0.4",
            zorder=1,
        )
    for name, (_, xyz) in recording.targets.items():
        if not len(xyz):
            continue
        # A wide grey band under the vehicles' paths: a tracker following the target
        # flies on it and stays visible.
        ax.plot(
            xyz[:, 0], xyz[:, 1], linestyle="--", color="0.45", linewidth=4.0, alpha=0.6, zorder=1.5
        )
        ax.scatter([xyz[-1, 0]], [xyz[-1, 1]], marker="D", s=40, color="black", zorder=6)
        ax.annotate(
            name,
            (float(xyz[-1, 0]), float(xyz[-1, 1])),
            textcoords="offset points",
            xytext=(5, 4),
            fontsize=8,
            fontweight="bold",
            zorder=7,
        )


def _first_start(spans: Sequence[Span], label: str) -> float:
    """When the first actor of ``label`` first started (infinity when never)."""
    names = set(label.split("+"))
    starts = [start for _, actor, start, _ in spans if actor in names]
    return min(starts, default=float("inf"))


def timeline_png(recording: Recording, out: Path) -> Path:
    """Draw how many platforms ran each actor over time into the PNG ``out``: a stacked
    step area, one band per actor, with a dashed line and caption at each collective
    transition. Returns ``out``.
    """
    spans = actor_timeline(recording.transitions)
    end = recording.end_time()
    fig = Figure(figsize=(9.0, 4.5), layout="constrained")
    ax: Axes = fig.add_subplot()
    ax.set_title(_title(recording, "platforms per actor"))
    ax.set_xlabel("time (s)")
    ax.set_ylabel("platforms running the actor")
    ax.grid(True, axis="y", linewidth=0.4, alpha=0.5)

    actors: list[str] = []
    for _, actor, _, _ in sorted(spans, key=lambda s: s[2]):
        if actor not in actors:
            actors.append(actor)
    if not actors:
        ax.text(
            0.5, 0.5, "no transitions recorded", ha="center", va="center", transform=ax.transAxes
        )
        return _save(fig, out)

    edges = {0.0, end}
    for _, _, start, stop in spans:
        edges.add(start)
        if stop is not None:
            edges.add(stop)
    times = np.array(sorted(edges))
    counts = {
        actor: np.array(
            [
                sum(
                    1
                    for _, a, start, stop in spans
                    if a == actor and start <= t and (stop is None or t < stop)
                )
                for t in times
            ],
            dtype=np.float64,
        )
        for actor in actors
    }
    colour = _colours(actors)
    base = np.zeros(len(times))
    for actor in actors:
        top = base + counts[actor]
        ax.fill_between(
            times,
            base,
            top,
            step="post",
            color=colour[actor],
            alpha=0.75,
            label=actor,
            linewidth=0,
        )
        ax.step(times, top, where="post", color=colour[actor], linewidth=1.0)
        base = top
    peak = float(base.max()) if len(base) else 1.0

    _captions(ax, recording, end, peak)
    ax.set_xlim(0.0, max(end, 1e-9))
    ax.set_ylim(0.0, max(peak, 1.0) * 1.15)
    ax.legend(loc="lower right", fontsize=8, framealpha=0.9)
    return _save(fig, out)


def _captions(ax: Axes, recording: Recording, end: float, peak: float) -> None:
    """A dashed line at each collective transition and its caption, the parts of one
    release in one caption; a caption goes on the highest row where it overlaps none
    (widths estimated from the text at 8 pt on the 9-inch figure)."""
    groups: dict[tuple[str, float], list[str]] = {}
    for moment in _collectives(recording):
        move = f"{len(moment.platforms)} × {moment.src or '-'} → {moment.dst or '-'}"
        groups.setdefault((moment.label, round(moment.t, 1)), []).append(move)
    span = max(end, 1e-9)
    per_char = span * 4.6 / 560.0  # data units per character: 8 pt text, ~560 pt of axes
    rows: list[list[tuple[float, float]]] = []
    for (label, t), moves in sorted(groups.items(), key=lambda g: g[0][1]):
        ax.axvline(t, color="black", linestyle="--", linewidth=0.9, zorder=3)
        text = f"{label} ({', '.join(moves)})"
        width = per_char * (len(text) + 2)
        right = t + width > span  # no room to the right: the caption ends at its line
        x0, x1 = (t - width, t) if right else (t, t + width)
        row = next(
            (i for i, taken in enumerate(rows) if all(x1 < a or x0 > b for a, b in taken)),
            len(rows),
        )
        if row == len(rows):
            rows.append([])
        rows[row].append((x0, x1))
        ax.annotate(
            text,
            (t, peak * (1.04 - 0.07 * row)),
            textcoords="offset points",
            xytext=(-3 if right else 3, 0),
            ha="right" if right else "left",
            fontsize=8,
            va="top",
            bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.8},
            zorder=4,
        )
