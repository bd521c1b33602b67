"""The command line's recording options: ``--record`` (MCAP), ``--live`` (a Foxglove view),
``--origin`` (map positions), and ``actorswarm record convert`` (an older JSON Lines
recording to MCAP).

Every error here is one line naming the file or option and what to do; the commands exit 2.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

if TYPE_CHECKING:
    from actorswarm.recording.live import LiveSink
    from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim
    from actorswarm.vehicles.mavlink.frame import MissionFrame

__all__ = [
    "LIVE_PORT",
    "LiveHostOpt",
    "LiveOpt",
    "LivePortOpt",
    "OriginOpt",
    "open_live",
    "parse_origin_option",
    "record_app",
    "sim_live",
    "write_sim_record",
]

#: The live view's default port (:data:`actorswarm.recording.live.DEFAULT_LIVE_PORT`, kept
#: here too so that the command line loads no recording module until one is used).
LIVE_PORT = 8766

LiveOpt = Annotated[
    bool,
    typer.Option(
        "--live",
        help="Serve the run's channels to Foxglove over its WebSocket protocol as it runs (sim: "
        "paced by --speed) "
        "(needs the foxglove extra).",
    ),
]
LiveHostOpt = Annotated[
    str, typer.Option(help="Address of the live Foxglove view (default: loopback only).")
]
LivePortOpt = Annotated[
    int, typer.Option(min=0, max=65535, help="Port of the live Foxglove view (0: any free).")
]
OriginOpt = Annotated[
    str | None,
    typer.Option(
        metavar="LAT,LON,ALT",
        help="Geodetic origin of the mission frame: the recording then has map positions "
        "(/fix) for Foxglove's Map panel.",
    ),
]

record_app = typer.Typer(
    help="Recordings: convert an older JSON Lines recording to MCAP.", no_args_is_help=True
)


def _fail(text: str) -> typer.Exit:
    typer.echo(text, err=True)
    return typer.Exit(2)


def parse_origin_option(text: str | None) -> MissionFrame | None:
    """``--origin`` as a frame (None when not given); exit 2 with the reason when malformed."""
    if text is None:
        return None
    from actorswarm.vehicles.mavlink.frame import parse_origin

    try:
        return parse_origin(text, "--origin")
    except ValueError as exc:
        raise _fail(str(exc)) from None


def open_live(host: str, port: int, name: str) -> LiveSink:
    """Start the live Foxglove view and say where it is; exit 2 when it cannot start."""
    from actorswarm.recording.live import LiveSink, LiveUnavailable

    try:
        live = LiveSink(host=host, port=port, name=name)
    except LiveUnavailable as exc:
        raise _fail(f"--live: {exc}") from None
    typer.echo(f"live Foxglove view on {live.url} (Foxglove: Open connection → {live.url})")
    return live


def write_sim_record(
    path: Path, run: TaskSim, report: dict[str, Any], meta: dict[str, Any], script: Path,
    origin: MissionFrame | None, packets: list[tuple[float, int]], faults: list[Fault],
) -> None:  # fmt: skip
    """Write a finished ``sim`` run to the MCAP file ``path``; exit 2 when it cannot."""
    from actorswarm.recording import RecordingWriteError, write_simulation

    world = run.world
    areas = world.area_polygons() if world is not None else None
    try:
        write_simulation(
            path,
            report,
            meta=meta,
            track=None if world is None else world.track(),
            areas=areas,
            script=(script.name, script.read_text(errors="replace")),
            packets=packets,
            origin=origin,
            faults=faults,
        )
    except RecordingWriteError as exc:
        raise _fail(str(exc)) from None


def sim_live(
    run: TaskSim, script: Path, meta: dict[str, Any], duration: float, speed: float,
    events: list[GroundEvent], faults: list[Fault], live: tuple[str, int], record: Path | None,
    origin: MissionFrame | None,
) -> dict[str, Any]:  # fmt: skip
    """``sim --live``: serve the run to Foxglove on ``live`` (host, port), and record it to
    ``record`` as well when given, while it runs paced to ``speed`` × the wall clock with
    its ``events`` and ``faults``; Ctrl-C ends it early. Returns the report."""
    from actorswarm.recording import McapSink, Recorder, RecordingWriteError, Sink
    from actorswarm.recording.simulation import record_live

    sinks: list[Sink] = [open_live(live[0], live[1], f"sim {script.name}")]
    if record is not None:
        try:
            sinks.append(McapSink(record))
        except RecordingWriteError as exc:
            sinks[0].close()
            raise _fail(str(exc)) from None
    areas = run.world.area_polygons() if run.world is not None else None
    text = script.read_text(errors="replace")
    recorder = Recorder(sinks, meta=meta, script=(script.name, text), areas=areas, origin=origin)
    run.schedule(events, faults)
    started = time.monotonic()

    def pace(t: float) -> None:
        # Pacing is the front end's business: the simulation never reads a clock.
        ahead = t / speed - (time.monotonic() - started)
        if ahead > 0:
            time.sleep(ahead)

    try:
        return record_live(run, duration, recorder, on_slice=pace, faults=faults)
    except KeyboardInterrupt:
        return run.report()
    finally:
        recorder.close()


@record_app.command("convert")
def record_convert(
    source: Annotated[Path, typer.Argument(help="A JSON Lines recording (an older version's).")],
    out: Annotated[Path, typer.Argument(help="The MCAP recording to write.")],
) -> None:
    """Write an older JSON Lines recording as MCAP (what Foxglove and web --replay open)."""
    from actorswarm.recording import McapSink, Recorder, RecordingWriteError, read_recording
    from actorswarm.recording.convert import replay_into
    from actorswarm.sim.record import RecordError

    try:
        data = read_recording(source)
    except (RecordError, OSError) as exc:
        raise _fail(f"{source}: {exc}" if str(source) not in str(exc) else str(exc)) from None
    try:
        sink = McapSink(out, atomic=True)
    except RecordingWriteError as exc:
        raise _fail(str(exc)) from None
    meta = {k: v for k, v in data.meta.items() if k != "script_text"}
    recorder = Recorder([sink], meta=meta, areas=data.areas())
    replay_into(recorder, data)
    try:
        recorder.close()
    except RecordingWriteError as exc:
        raise _fail(str(exc)) from None
    typer.echo(f"wrote {out}")
