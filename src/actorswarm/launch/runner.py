"""Run a launch file: start its daemons, show them, restart one on request, stop them all.

The daemons are :class:`~actorswarm.daemon.launch.LocalSwarm` processes, each in a session of
its own, so a Ctrl-C at the terminal reaches the launcher only; the launcher then stops
every daemon with SIGTERM (their clean stop: they leave the swarm and back up their actors)
and waits for them. A daemon still running after :data:`STOP_WAIT` seconds is killed.

Requests, one per line, from the launcher's standard input or from the control file
``DIRECTORY/launch.control`` (which ``actorswarm launch FILE --restart ID`` writes from
another terminal): ``r ID`` / ``restart ID`` stops that daemon and starts it again from its
state directory; ``q`` / ``quit`` stops them all, as Ctrl-C does.

With autopilots (``vehicle = "mavlink"``, :mod:`actorswarm.launch.autopilots`), each
platform's autopilot is started before its daemon (when the file gives a command), the
launcher says when each daemon's link to it comes up, or that it has not within the
table's ``link_timeout``, and when an autopilot exits; ``r ID`` starts an autopilot that
exited again, with the daemon; the autopilots are stopped after the daemons.
"""

from __future__ import annotations

import contextlib
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import TextIO

from rich.console import Console
from rich.live import Live
from rich.table import Table

from actorswarm.daemon.launch import LocalSwarm, free_ports
from actorswarm.launch.autopilots import Autopilots
from actorswarm.launch.config import LaunchFile
from actorswarm.launch.monitor import Row, read_status, sample

__all__ = ["CONTROL", "PIDFILE", "STOP_WAIT", "Launcher", "request"]

#: Seconds a daemon gets to stop cleanly after SIGTERM before it is killed.
STOP_WAIT = 15.0
#: The control file and the launcher's pid file, in the launch directory.
CONTROL = "launch.control"
PIDFILE = "launch.pid"


def request(directory: Path, line: str) -> str | None:
    """Hand ``line`` to the launcher running on ``directory``; None when done, else why not
    (no launcher running there)."""
    try:
        pid = int((directory / PIDFILE).read_text().strip())
        os.kill(pid, 0)
    except (OSError, ValueError):
        return f"no launcher is running on {directory} (no live {PIDFILE} there)"
    with (directory / CONTROL).open("a", encoding="utf-8") as control:
        control.write(line.strip() + "\n")
    return None


class Launcher:
    """The daemons of one launch file and what is known of them."""

    def __init__(self, plan: LaunchFile, keys: Path | None, console: Console) -> None:
        self.plan = plan
        self.console = console
        self.directory = plan.directory
        endpoints: list[str] | None = None
        if not plan.multicast:
            ports = plan.ports or tuple(free_ports(len(plan.plans)))
            endpoints = [f"tcp/{plan.host}:{port}" for port in ports]
        self.swarm = LocalSwarm(
            plan.directory,
            len(plan.plans),
            swarm=plan.swarm,
            secure=not plan.insecure,
            endpoints=endpoints,
            platforms=plan.platforms,
            keys=keys,
            multicast=plan.multicast,
            state_dirs={p.platform: p.state_dir for p in plan.plans},
            new_session=True,
        )
        self.rows = {p.platform: Row(p.platform) for p in plan.plans}
        self._plans = {p.platform: p for p in plan.plans}
        self._requests: queue.Queue[str] = queue.Queue()
        self._stop = threading.Event()
        self._keys = keys
        self.web: subprocess.Popen[bytes] | None = None
        self.autopilots = (
            None
            if plan.autopilots is None
            else Autopilots(plan.autopilots, plan.mavlink_platforms(), plan.directory)
        )
        #: Platforms flying an autopilot: when their daemon started, and whether the link
        #: was reported (up, or late).
        self._links: dict[int, tuple[float, str]] = {}

    # --- the web ground station ---------------------------------------------------------

    def web_command(self) -> list[str]:
        """``actorswarm gs web`` for this swarm (its name, keys and endpoints, and the world
        its simulated vehicles share)."""
        assert self.plan.web is not None
        cmd = [sys.executable, "-m", "actorswarm", "gs", "web", "--swarm", self.plan.swarm,
               "--port", str(self.plan.web)]  # fmt: skip
        cmd += ["--insecure"] if self.plan.insecure else ["--keys", str(self._keys)]
        world = self.plan.shared_world()
        if world is not None:
            cmd += ["--world", str(world)]
        if self.swarm.endpoints:
            cmd.append("--no-multicast")
        for endpoint in self.swarm.endpoints:
            cmd += ["--connect", endpoint]
        return cmd

    def start_web(self) -> None:
        log = self.directory / "web.log"
        with log.open("ab") as out:
            self.web = subprocess.Popen(
                self.web_command(), stdout=out, stderr=out, start_new_session=True
            )
        self.say(f"web ground station: http://127.0.0.1:{self.plan.web}/ (log {log})")

    def stop_web(self) -> None:
        """SIGINT, as the operator's Ctrl-C would (it exits 130 then); killed after
        :data:`STOP_WAIT`."""
        if self.web is None:
            return
        if self.web.poll() is None:
            self.web.send_signal(signal.SIGINT)
        self.say(f"web ground station: stopped, exit {_wait(self.web)}")
        self.web = None

    # --- processes ----------------------------------------------------------------------

    def start(self, platform: int) -> None:
        if self.autopilots is not None and platform in self.autopilots.index:
            said = self.autopilots.start(platform)
            if said is not None:
                self.say(said)
            self._links[platform] = (time.monotonic(), "waiting")
        proc = self.swarm.start(platform, *self.plan.daemon_args(self._plans[platform]))
        row = self.rows[platform]
        row.pid, row.up, row.exit_code, row.last = proc.pid, True, None, None
        where = self.swarm.endpoint(platform) or "multicast"
        self.say(f"platform {platform}: pid {proc.pid}, {where}, log {self.swarm.log(platform)}")

    def stop_one(self, platform: int, *, signalled: bool = False) -> int | None:
        """SIGTERM (unless ``signalled`` already: a second one would cut its clean stop
        short), then wait (kill after :data:`STOP_WAIT`); its exit status."""
        proc = self.swarm.procs.pop(platform, None)
        if proc is None:
            return None
        if not signalled and proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        code = _wait(proc)
        self.rows[platform].up, self.rows[platform].exit_code = False, code
        return code

    def stop_all(self) -> dict[int, int]:
        """Every running daemon stopped, all signalled first so they stop together."""
        procs = dict(self.swarm.procs)
        for proc in procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        codes = {}
        for platform in procs:
            code = self.stop_one(platform, signalled=True)
            codes[platform] = -9 if code is None else code
        if self.autopilots is not None:
            for platform, code in sorted(self.autopilots.stop_all().items()):
                self.say(f"platform {platform}: autopilot stopped, exit {code}")
        return codes

    def restart(self, platform: int) -> None:
        if platform not in self.rows:
            self.say(f"no platform {platform} in this launch: {self.plan.platforms}")
            return
        code = self.stop_one(platform)
        if code is not None:
            self.say(f"platform {platform} stopped (exit {code})")
        self.rows[platform].restarts += 1
        self.start(platform)

    # --- requests -----------------------------------------------------------------------

    def handle(self, line: str) -> None:
        """One request line (see the module docstring)."""
        words = line.split()
        if not words:
            return
        verb = words[0].lower()
        if verb in ("q", "quit", "stop"):
            self._stop.set()
        elif verb in ("r", "restart") and len(words) == 2 and words[1].isdigit():
            self.restart(int(words[1]))
        else:
            self.say(f"{line.strip()!r}: say `r ID` to restart a platform, `q` to stop all")

    def _read_control(self) -> None:
        path = self.directory / CONTROL
        try:
            text = path.read_text(encoding="utf-8")
            path.unlink()
        except OSError:
            return
        for line in text.splitlines():
            self.handle(line)

    def listen(self, stream: TextIO) -> None:
        """Read request lines from ``stream`` in the background."""

        def read() -> None:
            for line in stream:
                self._requests.put(line)

        threading.Thread(target=read, name="launch-requests", daemon=True).start()

    # --- the loop -----------------------------------------------------------------------

    def say(self, text: str) -> None:
        self.console.print(text, markup=False, highlight=False, soft_wrap=True)

    def refresh(self) -> None:
        """Poll every process, read its status and /proc figures."""
        now = time.monotonic()
        for platform, row in self.rows.items():
            proc = self.swarm.procs.get(platform)
            if proc is not None and row.up and proc.poll() is not None:
                row.up, row.exit_code = False, proc.returncode
                self.swarm.procs.pop(platform)
                self.say(
                    f"platform {platform} exited with status {proc.returncode}: "
                    f"`r {platform}` starts it again; its log: {self.swarm.log(platform)}"
                )
            figures = sample(row.pid, now) if row.up and row.pid is not None else None
            status = read_status(self.swarm.state_dir(platform))
            row.update(status, figures)
            if platform in self._links:
                self._watch_link(platform, status, now)
        if self.autopilots is not None:
            for platform, code in self.autopilots.exited():
                self.say(
                    f"platform {platform}: its autopilot exited with status {code}: "
                    f"`r {platform}` starts it again; its log: {self.autopilots.log(platform)}"
                )

    def _watch_link(self, platform: int, status: dict[str, object], now: float) -> None:
        """Say when the daemon's link to its autopilot comes up, or that it has not within
        the launch file's ``link_timeout``."""
        assert self.autopilots is not None
        since, said = self._links[platform]
        vehicle = status.get("vehicle")
        link = vehicle.get("link") if isinstance(vehicle, dict) else None
        written = status.get("t")
        if not isinstance(written, int | float) or written < since:
            link = None  # the status of the daemon before a restart (its ``t``: the host's
            # monotonic clock, as ours)
        if link == "up" and said != "up":
            self._links[platform] = (since, "up")
            self.say(f"platform {platform}: autopilot link up after {now - since:.1f} s")
        elif said == "waiting" and now - since > self.autopilots.spec.link_timeout:
            self._links[platform] = (since, "late")
            where = f"{self.autopilots.log(platform)} and " if self.autopilots.spec.command else ""
            self.say(
                f"platform {platform}: no link to its autopilot after "
                f"{self.autopilots.spec.link_timeout:g} s; see {where}{self.swarm.log(platform)}"
            )

    def table(self) -> Table:
        table = Table(title=f"swarm {self.plan.swarm}: r ID + Enter restarts one, Ctrl-C stops all")
        for name in ("platform", "pid", "up", "master", "actors", "incarnation", "CPU", "RSS"):
            table.add_column(name, justify="left" if name == "actors" else "right")
        for row in self.rows.values():
            up = "up" if row.up else f"exit {row.exit_code}" if row.exit_code is not None else "-"
            if row.restarts:
                up += f" (restarted {row.restarts})"
            table.add_row(
                str(row.platform),
                "-" if row.pid is None else str(row.pid),
                up,
                "-" if row.master is None else str(row.master),
                ", ".join(row.actors) or "-",
                "-" if row.incarnation is None else str(row.incarnation),
                "-" if row.cpu_percent is None else f"{row.cpu_percent:.1f} %",
                "-" if row.rss is None else f"{row.rss / 2**20:.0f} MiB",
            )
        return table

    def summary(self) -> str:
        """One line: how many are up and which master they follow."""
        up = [r for r in self.rows.values() if r.up]
        masters = {r.master for r in up}
        master = masters.pop() if len(masters) == 1 else None
        said = "no agreed master" if master is None else f"master {master}"
        return f"{len(up)} of {len(self.rows)} up, {said}"

    def run(self, *, live: bool, interval: float = 1.0) -> int:
        """Start every daemon and watch them until Ctrl-C, SIGTERM or ``q``; then stop them
        all. Returns 0 when every daemon stopped cleanly, 1 otherwise."""
        self.directory.mkdir(parents=True, exist_ok=True)
        (self.directory / CONTROL).unlink(missing_ok=True)
        (self.directory / PIDFILE).write_text(f"{os.getpid()}\n")
        previous = _catch(self._stop.set)
        try:
            for plan in self.plan.plans:
                self.start(plan.platform)
            if self.plan.web is not None:
                self.start_web()
            self._watch(live, interval)
        finally:
            _restore(previous)
            self.stop_web()
            self.say("stopping every daemon (SIGTERM) ...")
            codes = self.stop_all()
            self.swarm.close()
            (self.directory / PIDFILE).unlink(missing_ok=True)
        unclean = {p: c for p, c in codes.items() if c != 0}
        for platform, code in sorted(codes.items()):
            self.say(f"platform {platform}: stopped, exit {code}")
        return 1 if unclean else 0

    def _watch(self, live: bool, interval: float) -> None:
        shown = ""
        view = Live(self.table(), console=self.console, auto_refresh=False) if live else None
        next_refresh = 0.0
        with view if view is not None else _Nothing():
            while not self._stop.is_set():
                with contextlib.suppress(queue.Empty):
                    self.handle(self._requests.get(timeout=0.1))
                self._read_control()
                if time.monotonic() < next_refresh:
                    continue
                next_refresh = time.monotonic() + interval
                self.refresh()
                if view is not None:
                    view.update(self.table(), refresh=True)
                elif (line := self.summary()) != shown:
                    shown = line
                    self.say(line)


class _Nothing:
    def __enter__(self) -> None:
        return None

    def __exit__(self, *exc: object) -> None:
        return None


def _wait(proc: subprocess.Popen[bytes]) -> int:
    try:
        return proc.wait(timeout=STOP_WAIT)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.wait()


_Handler = Callable[[int, FrameType | None], object] | int | None


def _catch(stop: Callable[[], None]) -> dict[int, _Handler]:
    """SIGINT and SIGTERM set the stop flag (in the main thread only: elsewhere, as in a
    test's thread, the caller stops the launcher itself)."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    previous: dict[int, _Handler] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, lambda _s, _f: stop())
    return previous


def _restore(previous: dict[int, _Handler]) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
