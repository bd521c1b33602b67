"""``actorswarm demo``: run a shipped mission in the simulator and show it.

The front end of :mod:`actorswarm.sim.mission`: a progress bar over the mission's virtual
time, one line per collective transition as it happens (how many platforms moved from which
actor to which, on what event, and how long the switch took from the first platform to the
last), then the pictures (trajectories and timeline), the recording and the JSON report in
the output directory, and a one-screen summary. ``realtime`` paces the run to the wall
clock; by default it runs as fast as the machine allows.

The exit status is :func:`actorswarm.sim.verdict.verdict`'s, with completion expected (a
shipped mission is meant to complete): :func:`demo_status` says it and why.
"""

from __future__ import annotations

import json
import time
from collections import Counter
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from actorswarm.missions import Mission
from actorswarm.recording import read_recording, write_simulation
from actorswarm.sim.mission import prepare, run_slices
from actorswarm.sim.tasksim import Fault, failure_lines, steps
from actorswarm.sim.verdict import verdict
from actorswarm.viz import timeline_png, trajectory_png
from actorswarm.world.separation import BREACH_PREFIX, separation_line

__all__ = ["demo_status", "describe_steps", "run_demo"]


def describe_steps(records: list[dict[str, Any]]) -> list[str]:
    """One line per group of transitions that moved together (same event, from and to)."""
    lines = []
    for first, last, event, src, dst, cause, who in steps(records):
        on = f" on {event}" if event else ""
        lines.append(
            f"{first:7.1f} s  {len(who):3d} × {src or '-'} → {dst or '-'} ({cause}{on}), "
            f"switched within {(last - first) * 1000.0:.0f} ms"
        )
    return lines


def demo_status(report: dict[str, Any], console: Console) -> tuple[int, list[str]]:
    """Print every plugin failure of a finished mission's ``report`` on ``console`` (one
    line each, as ``actorswarm sim`` lists them) and return the exit status with why the
    run failed, one line (none when it went as asked). The status is the one
    ``actorswarm sim --expect-complete`` gives the same run: 0 as asked, 1 an invariant
    violated, 3 a plugin failed, 4 the mission did not complete."""
    for line in failure_lines(report["plugin_failures"]):
        # Not markup: an error message may hold brackets.
        console.print(line, markup=False, highlight=False, soft_wrap=True, style="red")
    return verdict(report, expect_complete=True)


def _summary_table(report: dict[str, Any], mission: Mission) -> Table:
    table = Table(title=f"summary of the {mission.name} mission", show_header=False, box=None)
    table.add_column(style="bold")
    table.add_column()
    switches = [t for t in report["transitions"] if t["cause"] != "start"]
    causes = Counter(t["cause"] for t in switches)
    table.add_row("completed", "yes" if report["completed"] else "NO")
    table.add_row("simulated", f"{report['sim_time_s']:.0f} s")
    table.add_row(
        "transitions", f"{len(switches)} ({', '.join(f'{n} {c}' for c, n in causes.items())})"
    )
    masters = report["masters"]
    table.add_row(
        "masters",
        ", ".join(f"{m['platform']} from {m['t']:.1f} s (epoch {m['epoch']})" for m in masters)
        or "none",
    )
    traffic = report["traffic"]
    sent = sum(row["sent_packets"] for row in traffic.values())
    sent_bytes = sum(row["sent_bytes"] for row in traffic.values())
    seconds = max(report["sim_time_s"], 1e-9)
    table.add_row(
        "packets",
        f"{sent} sent by the swarm ({sent / seconds:.0f}/s, {sent_bytes / 1e6:.1f} MB; "
        "a broadcast counts once)",
    )
    if masters and str(masters[-1]["platform"]) in traffic:
        row = traffic[str(masters[-1]["platform"])]
        table.add_row(
            "at the master",
            f"{row['sent_packets'] / seconds:.0f} sent/s, {row['recv_packets'] / seconds:.0f} "
            "received/s",
        )
    finals = Counter(",".join(a) or "-" for a in report["final_actors"].values())
    table.add_row("final actors", ", ".join(f"{a} on {n}" for a, n in finals.items()))
    if report.get("wrecks"):
        table.add_row(
            "lost vehicles",
            ", ".join(f"platform {w['platform']} at {w['t']:.1f} s" for w in report["wrecks"]),
        )
    if report["plugin_failures"]:
        table.add_row("plugin failures", str(len(report["plugin_failures"])))
    separation = report.get("separation")
    if separation is not None:
        table.add_row("separation", separation_line(separation).removeprefix("separation: "))
    invariants = [v for v in report["violations"] if not v.startswith(BREACH_PREFIX)]
    table.add_row("invariants", "all held" if not invariants else "; ".join(invariants))
    return table


def run_demo(
    mission: Mission,
    *,
    out: Path,
    platforms: int | None,
    seed: int,
    loss: float,
    realtime: bool,
    kills: tuple[tuple[int, float], ...] = (),
    console: Console | None = None,
) -> dict[str, Any]:
    """Run ``mission``, show it on ``console`` and write its files to ``out``; return the
    report (with ``files``: what was written)."""
    console = console or Console()
    out.mkdir(parents=True, exist_ok=True)
    n = platforms or mission.platforms
    console.print(
        f"[bold]{mission.title}[/bold]\n{n} platforms, seed {seed}, "
        f"{mission.duration:.0f} s of mission time"
        + (f", {loss:.0%} extra packet loss" if loss else "")
        + (", in real time" if realtime else "")
    )
    packets: list[tuple[float, int]] = []
    sim = prepare(mission, platforms=platforms, seed=seed, loss=loss, kills=kills, packets=packets)
    started = time.monotonic()
    with Progress(
        TextColumn("[progress.description]{task.description}"),
        BarColumn(),
        TextColumn("{task.completed:.0f}/{task.total:.0f} s"),
        TimeElapsedColumn(),
        console=console,
        transient=True,
    ) as progress:
        task = progress.add_task("simulating", total=mission.duration)

        def on_slice(t: float, new: list[dict[str, Any]]) -> None:
            for line in describe_steps(new):
                progress.console.print(line)
            progress.update(task, completed=t)
            if realtime:
                # Pacing is the front end's business: the simulation never reads a clock.
                ahead = t - (time.monotonic() - started)
                if ahead > 0:
                    time.sleep(ahead)

        report = run_slices(sim, mission.duration, on_slice=on_slice)
    wall = time.monotonic() - started
    record = out / "record.mcap"
    assert sim.world is not None
    write_simulation(
        record,
        report,
        track=sim.world.track(),
        packets=packets,
        areas=sim.world.area_polygons(),
        script=(mission.script_path.name, mission.script_path.read_text()),
        faults=[Fault("kill", t, frozenset({p})) for p, t in (*mission.kills, *kills)],
        meta={
            "script": sim.script.name,
            "mission": mission.name,
            "seed": seed,
            "platforms": n,
            "sim_time_s": report["sim_time_s"],
            "source": "actorswarm demo",
        },
    )
    recording = read_recording(record)
    files = [
        record,
        trajectory_png(recording, out / "trajectories.png"),
        timeline_png(recording, out / "timeline.png"),
    ]
    report_path = out / "report.json"
    report_path.write_text(json.dumps(report, indent=2) + "\n")
    files.append(report_path)
    console.print(_summary_table(report, mission))
    console.print(
        f"{report['sim_time_s']:.0f} s of mission simulated in {wall:.1f} s "
        f"({report['sim_time_s'] / max(wall, 1e-9):.1f}× real time)"
    )
    for path in files:
        console.print(f"wrote {path}")
    report["files"] = [str(p) for p in files]
    return report
