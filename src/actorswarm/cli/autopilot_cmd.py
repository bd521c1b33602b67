"""``actorswarm autopilot``: a simulated MAVLink autopilot (ArduCopter, ArduPlane or PX4)
for one vehicle, until SIGTERM or SIGINT (:mod:`actorswarm.vehicles.mavlink.autopilot`).

pymavlink is imported only when the command runs.
"""

from __future__ import annotations

import math
import signal
import sys
import threading
from enum import StrEnum
from typing import Annotated

import typer

__all__ = ["autopilot"]


class AutopilotKind(StrEnum):
    ardupilot = "ardupilot"
    px4 = "px4"


class AutopilotFrame(StrEnum):
    copter = "copter"
    plane = "plane"


def autopilot(
    home: Annotated[
        str,
        typer.Option(
            help="Where it stands: LAT,LON,ALT (degrees, degrees, metres AMSL), and for a "
            "--frame plane optionally ,HEADING: where it faces down its runway, degrees "
            "clockwise from north (default 0), as SITL's --home takes it."
        ),
    ],
    listen: Annotated[
        str,
        typer.Option(help="Its MAVLink endpoint, as pymavlink writes it (a daemon's udpout:)."),
    ] = "udpin:127.0.0.1:14560",
    sysid: Annotated[int, typer.Option(min=1, max=255, help="Its MAVLink system ID.")] = 1,
    kind: Annotated[
        AutopilotKind, typer.Option(help="Which autopilot it behaves as.")
    ] = AutopilotKind.ardupilot,
    frame: Annotated[
        AutopilotFrame,
        typer.Option(
            help="The airframe: a multicopter, or plane: a fixed-wing that plays ArduPlane "
            "4.5.7 (TAKEOFF, GUIDED, LOITER, RTL, AUTO modes, missions; --kind ardupilot "
            "only).",
        ),
    ] = AutopilotFrame.copter,
    failsafes: Annotated[
        bool,
        typer.Option(
            "--failsafes/--no-failsafes",
            help="Its link-loss and battery failsafe parameters on (1) or off (0).",
        ),
    ] = True,
    battery: Annotated[
        float, typer.Option(min=0.01, max=1.0, help="The charge at start, 0..1.")
    ] = 1.0,
    endurance: Annotated[
        float, typer.Option(min=1.0, help="Seconds of flight on a full battery at cruise speed.")
    ] = 1200.0,
    ready_after: Annotated[
        float | None,
        typer.Option(
            min=0.0,
            help="Seconds from boot until it accepts arming, refusing with the real "
            "autopilot's reasons before (default: as measured, 40 for ardupilot, 22 for "
            "ardupilot --frame plane, 35 for px4). "
            "On tcpin: its clock starts when the first client connects.",
        ),
    ] = None,
    withhold: Annotated[
        list[str] | None,
        typer.Option(
            metavar="MESSAGE",
            help="A message it never sends, even when asked for (a MAVLink name, e.g. "
            "EKF_STATUS_REPORT); repeat for more. To see what a vehicle does without it.",
        ),
    ] = None,
    ignore_message_interval: Annotated[
        bool,
        typer.Option(
            "--ignore-message-interval",
            help="ACK MAV_CMD_SET_MESSAGE_INTERVAL and do nothing (ArduPlane does so before "
            "its first HEARTBEAT).",
        ),
    ] = False,
    mavlink1: Annotated[
        bool,
        typer.Option("--mavlink1", help="Speak MAVLink 1 only (a link that drops MAVLink 2)."),
    ] = False,
) -> None:
    """Run a simulated MAVLink autopilot (quadrotor, or ArduPlane with --frame plane) for one
    vehicle until SIGTERM/SIGINT.

    It links as the firmware does: as ArduCopter's first serial port, it sends HEARTBEAT and
    little else until asked (SET_MESSAGE_INTERVAL, REQUEST_DATA_STREAM); as PX4's onboard
    link, it streams its default set unasked."""
    from actorswarm.vehicles.mavlink import MavlinkError
    from actorswarm.vehicles.mavlink.autopilot import AutopilotOptions, SimAutopilot
    from actorswarm.vehicles.mavlink.frame import parse_origin

    withheld = _message_ids(withhold or [])
    place, heading = _home_and_heading(home)
    busy = _udp_port_taken(listen)
    if busy:
        typer.echo(f"autopilot: --listen {listen}: {busy}; choose another port", err=True)
        raise typer.Exit(2)
    try:
        options = AutopilotOptions(
            listen,
            parse_origin(place, what="--home"),
            system=sysid,
            kind=kind.value,
            frame=frame.value,
            heading=heading,
            failsafes=failsafes,
            battery=battery,
            endurance=endurance,
            ready_after=ready_after,
            withheld=withheld,
            interval_ignored=ignore_message_interval,
            mavlink1=mavlink1,
        )
        sim = SimAutopilot(options)
    except (ValueError, MavlinkError) as exc:
        typer.echo(
            f"autopilot: {exc}" if not str(exc).startswith("autopilot") else str(exc), err=True
        )
        raise typer.Exit(2) from None
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    print(
        f"autopilot {sysid} ({kind.value}"
        f"{', plane' if frame is AutopilotFrame.plane else ''}) on {listen}, home {home}, "
        f"ready to arm {sim.boot.ready_after:g} s after boot",
        file=sys.stderr,
        flush=True,
    )
    try:
        sim.run(stop)
    finally:
        sim.close()


def _home_and_heading(home: str) -> tuple[str, float]:
    """``LAT,LON,ALT[,HEADING]`` -> (``LAT,LON,ALT``, heading); a bad heading is refused."""
    parts = home.split(",")
    if len(parts) != 4:
        return home, 0.0
    try:
        heading = float(parts[3])
    except ValueError:
        heading = math.nan
    if not math.isfinite(heading):
        typer.echo(f"autopilot: --home {home}: the heading {parts[3]!r} is not a number", err=True)
        raise typer.Exit(2)
    return ",".join(parts[:3]), heading


def _udp_port_taken(url: str) -> str:
    """Why the ``udpin:HOST:PORT`` endpoint ``url`` cannot be listened on, or "". pymavlink
    binds with SO_REUSEADDR, so a second autopilot on the same port would start silently
    and share the first one's packets: a bind without it says the port is taken."""
    import socket

    kind, _, rest = url.partition(":")
    host, sep, port = rest.rpartition(":")
    if kind != "udpin" or not sep or not port.isdigit():
        return ""
    try:
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        with socket.socket(family, socket.SOCK_DGRAM) as probe:
            probe.bind((host, int(port)))
    except OSError as exc:
        if isinstance(exc, socket.gaierror):
            return ""  # pymavlink says what is wrong with the name
        return f"{exc.strerror or exc} (another autopilot or program holds it)"
    return ""


def _message_ids(names: list[str]) -> frozenset[int]:
    """The MAVLink message IDs of ``names`` (exit 2 naming one that is not a message)."""
    from actorswarm.vehicles.mavlink.dialect import mav

    out: set[int] = set()
    for name in names:
        message_id = getattr(mav, f"MAVLINK_MSG_ID_{name.strip().upper()}", None)
        if not isinstance(message_id, int):
            typer.echo(
                f"autopilot: --withhold {name}: not a MAVLink message name "
                "(write it as MAVLink does, e.g. EKF_STATUS_REPORT)",
                err=True,
            )
            raise typer.Exit(2)
        out.add(message_id)
    return frozenset(out)
