"""The autopilots of a launch file: one per platform, started from a command template or
already running (attached to), each daemon flying its own over MAVLink.

In the launch file::

    vehicle = "mavlink"
    origin = "47.397742,8.545594,488"     # the mission's origin, the same for every daemon

    [autopilot]
    # started by the launcher, one per platform (leave command out to attach to autopilots
    # already running); placeholders: {i} the instance (0, 1, ...), {platform}, {sysid},
    # {port}, {home} (LAT,LON,ALT: the origin moved {i} × spacing metres along bearing),
    # {here} (the directory the launch was started from)
    command = "arducopter -S -I{i} --model + --home {home},0 --defaults {here}/c.parm"
    workdir = true                        # each in DIRECTORY/autopilot-ID/ (default: here)
    mavlink = "tcp:127.0.0.1:{port}"      # each daemon's link to its autopilot
    port = 5760                           # {port} of instance 0 ...
    port_step = 10                        # ... and of instance i: port + i × port_step
    spacing = 4                           # metres between two instances' homes
    bearing = 90                          # the row of homes runs this way (degrees from
                                          # north, clockwise: 90 east; 0 north, for
                                          # fixed-wings side by side, each on its runway east)
    link_timeout = 60                     # seconds the launcher waits for each link

``{sysid}`` is the platform ID (an autopilot's system ID is 1..255). A command whose first
word is ``actorswarm`` runs this installation's (``python -m actorswarm``), so
``actorswarm autopilot --listen tcpin:127.0.0.1:{port} --sysid {sysid} --home {home}``
launches simulated autopilots. Each autopilot runs in a session of its own (a Ctrl-C at the
launcher's terminal reaches the launcher only), logging to ``DIRECTORY/autopilot-ID.log``;
the launcher stops them (SIGTERM, then a kill) after the daemons. With ``workdir = true``
each runs in a directory of its own, ``DIRECTORY/autopilot-ID/`` (made if missing), as
ArduPilot's own multi-vehicle launcher does: a SITL keeps its parameters (``eeprom.bin``),
logs and terrain in its working directory, and several started in one would share them
(name files of the launch's directory as ``{here}/FILE`` then).

:func:`read_autopilots` checks the table; :class:`Autopilots` runs the processes.
"""

from __future__ import annotations

import math
import shlex
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

__all__ = ["AUTOPILOT_KEYS", "AutopilotSpec", "Autopilots", "read_autopilots"]

AUTOPILOT_KEYS: Final = frozenset(
    {"command", "mavlink", "port", "port_step", "spacing", "bearing", "link_timeout", "workdir"}
)
_PLACES: Final = ("i", "platform", "sysid", "port", "home", "here")
#: Seconds an autopilot gets to stop after SIGTERM before it is killed.
_STOP_WAIT: Final = 10.0


@dataclass(frozen=True, slots=True)
class AutopilotSpec:
    """The ``[autopilot]`` table, checked."""

    origin: tuple[float, float, float]
    mavlink: str
    command: str | None = None
    port: int = 5760
    port_step: int = 10
    spacing: float = 4.0
    link_timeout: float = 60.0
    bearing: float = 90.0
    #: Each autopilot in a working directory of its own (:class:`Autopilots`).
    workdir: bool = False
    #: ``{here}``: the directory the launch was started from.
    here: str = "."

    def values(self, index: int, platform: int) -> dict[str, str]:
        """The placeholders' values for instance ``index`` (platform ``platform``)."""
        lat, lon, alt = self.origin
        way = math.radians(self.bearing)
        east, north = index * self.spacing * math.sin(way), index * self.spacing * math.cos(way)
        # A few hundred metres: the local flat-earth step is exact to well under a centimetre.
        lat_home = lat + math.degrees(north / 6378137.0)
        lon_home = lon + math.degrees(east / (6378137.0 * math.cos(math.radians(lat))))
        return {
            "i": str(index),
            "platform": str(platform),
            "sysid": str(platform),
            "port": str(self.port + index * self.port_step),
            "home": f"{lat_home:.7f},{lon_home:.7f},{alt:g}",
            "here": self.here,
        }

    def link(self, index: int, platform: int) -> str:
        """The daemon's ``--mavlink`` for instance ``index``."""
        return self.mavlink.format_map(self.values(index, platform))

    def argv(self, index: int, platform: int) -> list[str] | None:
        """The command of instance ``index`` (None: attach, start nothing)."""
        if self.command is None:
            return None
        words = [w.format_map(self.values(index, platform)) for w in shlex.split(self.command)]
        if words and words[0] == "actorswarm":
            words = [sys.executable, "-m", "actorswarm", *words[1:]]
        return words


def read_autopilots(
    table: dict[str, Any], origin: str | None, platforms: list[int]
) -> AutopilotSpec | str:
    """The spec of an ``[autopilot]`` table, or the problem (a line naming the key)."""
    from actorswarm.vehicles.mavlink.frame import parse_origin

    if origin is None:
        return 'origin: missing; vehicle = "mavlink" needs the mission origin "LAT,LON,ALT"'
    try:
        frame = parse_origin(origin, "origin")
    except ValueError as exc:
        return str(exc)
    for key in table:
        if key not in AUTOPILOT_KEYS:
            return (
                f"autopilot.{key}: unknown key; the keys are: {', '.join(sorted(AUTOPILOT_KEYS))}"
            )
    if max(platforms) > 255:
        return f"platforms: {max(platforms)}: an autopilot's system ID ({{sysid}}) is 1..255"
    mavlink = table.get("mavlink")
    if not isinstance(mavlink, str):
        return 'autopilot.mavlink: missing; each daemon\'s link, e.g. "tcp:127.0.0.1:{port}"'
    command = table.get("command")
    if command is not None and not isinstance(command, str):
        return f"autopilot.command: expected a string, not {command!r}"
    workdir = table.get("workdir", False)
    if not isinstance(workdir, bool):
        return f"autopilot.workdir: expected true or false, not {workdir!r}"
    numbers: dict[str, float] = {}
    for key, low in (
        ("port", 1),
        ("port_step", 0),
        ("spacing", 0),
        ("bearing", -360),
        ("link_timeout", 0.1),
    ):
        value = table.get(key)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, int | float) or value < low:
            return f"autopilot.{key}: expected a number >= {low:g}, not {value!r}"
        numbers[key] = value
    spec = AutopilotSpec(
        origin=(frame.lat, frame.lon, frame.alt),
        mavlink=mavlink,
        command=command,
        port=int(numbers.get("port", 5760)),
        port_step=int(numbers.get("port_step", 10)),
        spacing=float(numbers.get("spacing", 4.0)),
        bearing=float(numbers.get("bearing", 90.0)),
        link_timeout=float(numbers.get("link_timeout", 60.0)),
        workdir=workdir,
        here=str(Path.cwd()),
    )
    last = len(platforms) - 1
    if spec.port + last * spec.port_step > 65535:
        return (
            f"autopilot.port: instance {last} would need port {spec.port + last * spec.port_step}"
        )
    for key, text in (("mavlink", mavlink), ("command", command)):
        if text is None:
            continue
        try:
            text.format_map(spec.values(0, platforms[0]))
        except (KeyError, IndexError, ValueError) as exc:
            return (
                f"autopilot.{key}: {text!r}: bad placeholder {exc}; the placeholders are "
                + ", ".join("{" + p + "}" for p in _PLACES)
            )
    if command is not None:
        try:
            shlex.split(command)
        except ValueError as exc:
            return f"autopilot.command: {exc}"
    return spec


class Autopilots:
    """The autopilot processes of a launch (none when attaching)."""

    def __init__(self, spec: AutopilotSpec, platforms: list[int], directory: Path) -> None:
        self.spec = spec
        self.index = {platform: i for i, platform in enumerate(platforms)}
        self.directory = directory
        self.procs: dict[int, subprocess.Popen[bytes]] = {}

    def log(self, platform: int) -> Path:
        return self.directory / f"autopilot-{platform}.log"

    def workdir(self, platform: int) -> Path | None:
        """Where the autopilot of ``platform`` runs (None: where the launcher runs)."""
        return self.directory / f"autopilot-{platform}" if self.spec.workdir else None

    def start(self, platform: int) -> str | None:
        """Start the autopilot of ``platform`` unless it runs (or none is to be started);
        what to tell the operator (None: nothing)."""
        argv = self.spec.argv(self.index[platform], platform)
        running = self.procs.get(platform)
        if argv is None or (running is not None and running.poll() is None):
            return None
        cwd = self.workdir(platform)
        with self.log(platform).open("ab") as out:
            try:
                if cwd is not None:
                    cwd.mkdir(parents=True, exist_ok=True)
                proc = subprocess.Popen(
                    argv,
                    stdout=out,
                    stderr=out,
                    stdin=subprocess.DEVNULL,
                    start_new_session=True,
                    cwd=cwd,
                )
            except OSError as exc:
                return f"platform {platform}: cannot start its autopilot {argv[0]!r}: {exc}"
        self.procs[platform] = proc
        return f"platform {platform}: autopilot pid {proc.pid}, log {self.log(platform)}"

    def exited(self) -> list[tuple[int, int]]:
        """The autopilots that exited since the last call: ``(platform, status)``."""
        out = []
        for platform, proc in list(self.procs.items()):
            code = proc.poll()
            if code is not None:
                out.append((platform, code))
                del self.procs[platform]
        return out

    def stop_all(self) -> dict[int, int]:
        """SIGTERM to every autopilot, then wait (kill after a while); their exit statuses."""
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        codes = {}
        for platform, proc in self.procs.items():
            try:
                codes[platform] = proc.wait(timeout=_STOP_WAIT)
            except subprocess.TimeoutExpired:
                proc.kill()
                codes[platform] = proc.wait()
        self.procs.clear()
        return codes
