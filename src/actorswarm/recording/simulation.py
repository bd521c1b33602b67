"""A finished simulation written as a recording.

:func:`record_simulation` feeds a :class:`~actorswarm.recording.recorder.Recorder` a
simulation's facts in time order: the world's snapshots (poses with battery, targets), the
report's transitions, master changes, lost vehicles and plugin failures, and per snapshot
the packets per second the swarm sent; each collective switch adds its latency (first
platform to last, :func:`~actorswarm.sim.record.collective_transitions`).
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

from actorswarm.recording.mcap_sink import McapSink
from actorswarm.recording.recorder import Recorder, Sink
from actorswarm.sim.record import collective_transitions

if TYPE_CHECKING:
    from actorswarm.sim.tasksim import Fault, TaskSim
    from actorswarm.vehicles.mavlink.frame import MissionFrame
    from actorswarm.world.world import Track

__all__ = ["record_live", "record_simulation", "write_simulation"]

# Order of facts at one time: transitions before the snapshot that shows their colours.
_FACT, _SNAPSHOT = 0, 1
_FAULT_TEXT = {
    "kill": "crashed (simulated)",
    "restart": "restarted (simulated)",
    "partition": "cut off (simulated partition)",
    "heal": "every partition healed (simulated)",
}


def record_simulation(
    recorder: Recorder,
    report: Mapping[str, Any],
    *,
    track: Track | None = None,
    packets: Sequence[tuple[float, int]] = (),
    faults: Iterable[Fault] = (),
) -> None:
    """Write ``report`` (a :meth:`TaskSim.report`) and ``track`` (the world's snapshots,
    None without a world) to ``recorder``, in time order; ``packets`` are ``(t, packets
    sent so far)`` samples (:func:`~actorswarm.sim.record.sample_world`); ``faults`` the
    crashes, restarts, partitions and heals the run was given (events ``fault``)."""
    streams = [_facts(recorder, report, packets, faults)]
    if track is not None:
        streams.append(_snapshots(recorder, track))
    for _, _, _, write in heapq.merge(*streams, key=lambda item: item[:3]):
        write()


def _facts(
    recorder: Recorder,
    report: Mapping[str, Any],
    packets: Sequence[tuple[float, int]],
    faults: Iterable[Fault],
) -> Iterator[tuple[float, int, int, Callable[[], None]]]:
    items: list[tuple[float, int, int, Callable[[], None]]] = []
    n = 0

    def add(t: float, write: Callable[..., None], *args: Any, **kwargs: Any) -> None:
        nonlocal n
        items.append((float(t), _FACT, n, partial(write, *args, **kwargs)))
        n += 1

    for tr in report["transitions"]:
        add(tr["t"], recorder.transition, tr)
    for m in report["masters"]:
        add(m["t"], recorder.master, m["t"], [m["platform"]], m["epoch"])
    for f in faults:
        for p in sorted(f.ids) or [0]:
            add(f.t, recorder.event, f.t, "fault", p, _FAULT_TEXT.get(f.kind, f.kind))
    for w in report.get("wrecks", []):
        add(w["t"], recorder.event, w["t"], "fault", w["platform"], "vehicle lost")
    for f in report.get("plugin_failures", []):
        t, p = f.get("t", 0.0), f.get("platform", 0)
        text = f"plugin {f.get('plugin', '?')} failed: {f.get('error', '')}"
        add(t, recorder.event, t, "fault", p, text)
    for t, platform, text in _separation_events(report.get("separation")):
        add(t, recorder.event, t, "separation", platform, text)
    fleet = len(report.get("final_actors", {})) or None
    for c in collective_transitions(report["transitions"], fleet=fleet):
        ms = (c.t_last - c.t) * 1000.0
        add(c.t_last, recorder.metrics, c.t_last, barrier_latency_ms=ms)
    for (t0, n0), (t1, n1) in itertools.pairwise(packets):
        if t1 > t0:
            add(t1, recorder.metrics, t1, packets_per_s=(n1 - n0) / (t1 - t0))
    items.sort(key=lambda item: item[:3])
    yield from items


def _separation_events(
    separation: Mapping[str, Any] | None,
) -> Iterator[tuple[float, int, str]]:
    """``(t, platform, text)`` for each separation breach of a report's ``separation``
    (:meth:`~actorswarm.world.separation.SeparationReport.as_dict`), and for its closest
    approach: a recording says where the swarm came closest, breach or not."""
    if not separation:
        return
    for breach in separation.get("breaches", []):
        a, b = breach["platforms"]
        yield (
            breach["start"],
            a,
            f"separation breach: platforms {a} and {b} {breach['distance_m']:.2f} m apart "
            f"(minimum {breach['minimum_m']:g} m) from {breach['start']:.1f} s to "
            f"{breach['end']:.1f} s",
        )
    closest = separation.get("closest")
    if closest is not None:
        a, b = closest["platforms"]
        yield (
            closest["t"],
            a,
            f"closest approach of the run: platforms {a} and {b} {closest['distance_m']:.2f} m "
            f"apart (minimum {closest['minimum_m']:g} m)",
        )


def _snapshots(
    recorder: Recorder, track: Track
) -> Iterator[tuple[float, int, int, Callable[[], None]]]:
    from actorswarm.world.vehicles import MODES

    platforms = track.platforms.tolist()
    for i, t in enumerate(track.times.tolist()):

        def write(i: int = i, t: float = t) -> None:
            pos = track.positions[i].tolist()
            headings = track.headings[i].tolist()
            modes = track.modes[i].tolist()
            batteries = track.batteries[i].tolist()
            goals = track.goals[i].tolist() if len(track.goals) == len(track.times) else None
            for j, p in enumerate(platforms):
                x, y, z = pos[j]
                recorder.pose(t, p, x, y, z, headings[j], MODES[modes[j]], batteries[j])
                if goals is not None:
                    recorder.goal(t, p, *goals[j])
            for name, (x, y, z) in zip(
                track.target_names, track.target_positions[i].tolist(), strict=True
            ):
                recorder.target(t, name, x, y, z)
            recorder.snapshot(t)
            recorder.metrics(t, platforms_up=len(platforms))

        yield (t, _SNAPSHOT, i, write)


def write_simulation(
    path: Path | str,
    report: Mapping[str, Any],
    *,
    meta: Mapping[str, Any],
    track: Track | None = None,
    areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
    script: tuple[str, str] | None = None,
    packets: Sequence[tuple[float, int]] = (),
    origin: MissionFrame | None = None,
    faults: Iterable[Fault] = (),
    extra_sinks: Sequence[Sink] = (),
) -> None:
    """Write a finished simulation to the MCAP file ``path`` (whole or not at all:
    :class:`~actorswarm.recording.mcap_sink.RecordingWriteError` naming the file when it
    cannot be written). Times start at 0 (``t0_ns`` 0): the same run gives the same file."""
    sink = McapSink(path, atomic=True)
    recorder = Recorder([sink, *extra_sinks], meta=meta, script=script, areas=areas, origin=origin)
    try:
        record_simulation(recorder, report, track=track, packets=packets, faults=faults)
    except BaseException:
        sink.abandon()
        raise
    recorder.close()


def record_live(
    sim: TaskSim,
    duration: float,
    recorder: Recorder,
    *,
    slice_s: float = 0.5,
    on_slice: Callable[[float], None] | None = None,
    faults: Iterable[Fault] = (),
) -> dict[str, Any]:
    """Run ``sim`` to ``duration`` in slices of ``slice_s`` virtual seconds, writing each
    slice's facts to ``recorder`` as it ends (a live view; ``on_slice(t)`` after each, where
    the caller paces the run); return the report. ``sim`` must already sample its world
    (:func:`~actorswarm.sim.record.sample_world`) to have poses to show; ``faults`` are
    the ones scheduled (recorded as they come, not applied here). A collective
    switch cut by a slice's end counts as two in ``barrier_latency_ms``."""
    import dataclasses

    t = sim.swarm.now
    snapshots = masters = 0
    pending = sorted(faults, key=lambda f: f.t)
    packets: list[tuple[float, int]] = []
    while t < duration:
        t = min(duration, t + slice_s)
        new = sim.advance(t)
        facts: dict[str, Any] = {
            "transitions": new,
            "masters": [
                {"t": m.t, "platform": m.platform, "epoch": m.epoch}
                for m in sim.swarm.masters[masters:]
            ],
            "final_actors": {str(p): () for p in sim.hosts},
        }
        masters = len(sim.swarm.masters)
        track = None
        if sim.world is not None:
            whole = sim.world.track()
            track = dataclasses.replace(
                whole,
                times=whole.times[snapshots:],
                positions=whole.positions[snapshots:],
                headings=whole.headings[snapshots:],
                modes=whole.modes[snapshots:],
                batteries=whole.batteries[snapshots:],
                target_positions=whole.target_positions[snapshots:],
                goals=whole.goals[snapshots:],
            )
            snapshots = len(whole)
        traffic = sim.swarm.radio.traffic
        packets = [*packets[-1:], (t, sum(traffic.totals(p)[0] for p in traffic.platforms))]
        due = [f for f in pending if f.t <= t]
        pending = pending[len(due) :]
        record_simulation(recorder, facts, track=track, packets=packets, faults=due)
        if on_slice is not None:
            on_slice(t)
    return sim.report()
