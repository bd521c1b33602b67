"""A real swarm on one machine: daemon processes on loopback, for tests and benchmarks.

:class:`LocalSwarm` starts ``actorswarm daemon`` processes, each listening on its own
Zenoh endpoint and connecting to the others (no multicast, so it works where multicast is
filtered), authenticated with keys it creates; it runs the ``gs`` commands against them and
reads each daemon's ``status.json``. Everything lives in one directory (keys, state
directories, one log per daemon), which is what to look at when something fails: the
error of :meth:`LocalSwarm.wait` ends with the tail of every log.

``group`` puts the swarm on Zenoh's UDP multicast transport instead (``--broadcast
multicast``: every daemon and the ground station on that group, through ``interface``), no
endpoints and no scouting.

``wrap(platform)`` may prefix a daemon's command (``ip netns exec ns3``) and ``endpoints``
may give other addresses than loopback, which is how the network-namespace tests put
daemons behind emulated radio links. ``links`` says whom each daemon connects to (a chain,
a grid: neighbours only) and ``gs_connect`` where the ground station connects; with
``relay`` every daemon forwards for the others (``--relay``), so such a swarm stays one.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

__all__ = ["LocalSwarm", "free_ports"]


def free_ports(n: int) -> list[int]:
    """``n`` TCP ports on 127.0.0.1 that were free a moment ago."""
    socks = [socket.socket() for _ in range(n)]
    try:
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


class LocalSwarm:
    """Platforms ``1..size`` (or ``platforms``) as daemon processes, files under
    ``directory``.

    ``connect_all``: each daemon connects to every earlier one (a full mesh, the default)
    instead of to platform 1 only. ``extra`` arguments go to every daemon (``--vehicle
    sim``, ``--config FILE``). ``keys``: an existing key directory instead of one made under
    ``directory``. ``multicast``: the daemons find each other by multicast scouting, with no
    endpoints. ``state_dirs``: state directories other than ``directory/state-ID``.
    ``new_session``: each daemon in a session of its own, so a Ctrl-C at the terminal
    reaches only the process that started them (``actorswarm launch``), which stops them.
    ``env``: the daemons' whole environment (default: this process's). ``links``: the
    endpoints each platform connects to (default: every earlier platform's);
    ``gs_connect``: the ground station's (default: every platform's). ``relay``: every
    daemon relays (``--relay``, multi-hop).
    Use it as a context manager: leaving kills what still runs.
    """

    def __init__(
        self,
        directory: Path,
        size: int,
        *,
        swarm: str | None = None,
        secure: bool = True,
        endpoints: Sequence[str] | None = None,
        wrap: Callable[[int], Sequence[str]] | None = None,
        extra: Sequence[str] = (),
        platforms: Sequence[int] | None = None,
        keys: Path | None = None,
        multicast: bool = False,
        state_dirs: Mapping[int, Path] | None = None,
        new_session: bool = False,
        group: str | None = None,
        interface: str | None = None,
        env: Mapping[str, str] | None = None,
        links: Mapping[int, Sequence[str]] | None = None,
        gs_connect: Sequence[str] | None = None,
        relay: bool = False,
    ) -> None:
        # Created when something is written there (keys, logs): a launch that is only
        # checked leaves no trace.
        self.dir = Path(directory)
        self.platforms = list(platforms) if platforms is not None else list(range(1, size + 1))
        if len(self.platforms) != size:
            raise ValueError(f"{len(self.platforms)} platform IDs for {size} platforms")
        self.size = size
        self.swarm = swarm or f"local{os.getpid()}"
        self.secure = secure
        self.keys = self.dir / "keys" if keys is None else Path(keys)
        if secure and keys is None and not (self.keys / "swarm.key").exists():
            from actorswarm.security import init_keys

            self.dir.mkdir(parents=True, exist_ok=True)
            init_keys(self.keys)
        self.multicast = multicast
        #: The daemons' and the ground station's options of a multicast swarm.
        self.air: list[str] = []
        self.group, self.interface = group, interface
        if group is not None:
            if endpoints is not None or multicast:
                raise ValueError("a multicast group carries everything: no endpoints, no scouting")
            self.air = ["--broadcast", "multicast", "--group", group]
            self.air += ["--interface", interface] if interface is not None else []
        elif endpoints is None and not multicast:
            endpoints = [f"tcp/127.0.0.1:{p}" for p in free_ports(size)]
        if endpoints is not None and len(endpoints) != size:
            raise ValueError(f"{len(endpoints)} endpoints for {size} platforms")
        self.endpoints = list(endpoints or [])
        self.wrap = wrap
        self.extra = list(extra)
        self.state_dirs = dict(state_dirs or {})
        self.new_session = new_session
        self.env = None if env is None else dict(env)
        self.links = None if links is None else {p: list(e) for p, e in links.items()}
        self.gs_connect = None if gs_connect is None else list(gs_connect)
        if relay:
            self.extra.append("--relay")
        self.procs: dict[int, subprocess.Popen[bytes]] = {}

    def __enter__(self) -> LocalSwarm:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    # --- processes ----------------------------------------------------------------------

    def _security(self) -> list[str]:
        return ["--keys", str(self.keys)] if self.secure else ["--insecure"]

    def state_dir(self, platform: int) -> Path:
        return self.state_dirs.get(platform, self.dir / f"state-{platform}")

    def log(self, platform: int) -> Path:
        return self.dir / f"daemon-{platform}.log"

    def endpoint(self, platform: int) -> str | None:
        """Where ``platform`` listens (None: multicast scouting only)."""
        return self.endpoints[self.platforms.index(platform)] if self.endpoints else None

    def command(self, platform: int, *extra: str) -> list[str]:
        """The daemon command line of ``platform`` (without ``wrap``'s prefix)."""
        index = self.platforms.index(platform)
        args = [
            sys.executable, "-m", "actorswarm", "daemon", "--platform", str(platform),
            "--swarm", self.swarm, *self._security(),
            "--state-dir", str(self.state_dir(platform)), *self.air, *self.extra, *extra,
        ]  # fmt: skip
        if self.endpoints:
            args += ["--no-multicast", "--listen", self.endpoints[index]]
            links = self.endpoints[:index] if self.links is None else self.links.get(platform, [])
            for other in links:
                args += ["--connect", other]
        return args

    def start(self, platform: int, *extra: str) -> subprocess.Popen[bytes]:
        """Start platform ``platform`` (again, after a stop: from its state directory)."""
        if platform in self.procs:
            raise RuntimeError(f"platform {platform} is already running")
        args = self.command(platform, *extra)
        self.dir.mkdir(parents=True, exist_ok=True)
        prefix = list(self.wrap(platform)) if self.wrap is not None else []
        with self.log(platform).open("ab") as log:
            proc = subprocess.Popen(
                [*prefix, *args],
                stdout=log,
                stderr=log,
                start_new_session=self.new_session,
                env=self.env,
            )
        self.procs[platform] = proc
        return proc

    def start_all(self) -> None:
        for platform in self.platforms:
            self.start(platform)

    def stop(self, platform: int, sig: int = signal.SIGTERM) -> int:
        """Send ``sig`` to the platform's daemon and wait for it; returns its exit status."""
        proc = self.procs.pop(platform)
        proc.send_signal(sig)
        return proc.wait(timeout=15)

    def kill(self, platform: int) -> None:
        """``kill -9``: the daemon dies where it stands (no clean shutdown)."""
        self.stop(platform, signal.SIGKILL)

    def running(self) -> list[int]:
        return sorted(p for p, proc in self.procs.items() if proc.poll() is None)

    def close(self) -> None:
        for platform in list(self.procs):
            proc = self.procs.pop(platform)
            proc.kill()
            proc.wait(timeout=15)

    # --- the operator's side ------------------------------------------------------------

    def gs(
        self, *args: str, timeout: float = 60.0, keys: Path | None = None
    ) -> subprocess.CompletedProcess[str]:
        """Run ``actorswarm gs ARGS`` against this swarm (connected to every daemon), with
        the swarm's keys or those in ``keys`` (a ground station with other keys)."""
        security = self._security() if keys is None else ["--keys", str(keys)]
        cmd = [sys.executable, "-m", "actorswarm", "gs", *args, "--swarm", self.swarm,
               *security, *self.air]  # fmt: skip
        if self.endpoints:
            cmd.append("--no-multicast")
        for endpoint in self.endpoints if self.gs_connect is None else self.gs_connect:
            cmd += ["--connect", endpoint]
        prefix = list(self.wrap(0)) if self.wrap is not None else []
        return subprocess.run(
            [*prefix, *cmd], check=False, capture_output=True, text=True, timeout=timeout
        )

    def status(self, platform: int) -> dict[str, Any]:
        """The daemon's last ``status.json`` ({} before the first)."""
        path = self.state_dir(platform) / "status.json"
        try:
            return dict(json.loads(path.read_text()))
        except (OSError, ValueError):
            return {}

    def events(self, platform: int, event: str | None = None) -> list[dict[str, Any]]:
        """The JSON lines the daemon logged (every life of it), or those of one ``event``
        (``started``, ``master``, ``transition``, ``rejoined``...). Their ``t`` is the
        host's monotonic clock, the same as :func:`time.monotonic` in this process."""
        try:
            lines = self.log(platform).read_text(errors="replace").splitlines()
        except OSError:
            return []
        out = []
        for line in lines:
            try:
                record = json.loads(line)
            except ValueError:
                continue  # a library's plain-text warning
            if isinstance(record, dict) and (event is None or record.get("event") == event):
                out.append(record)
        return out

    def agreed_master(self, platforms: Sequence[int] | None = None) -> int | None:
        """The master every one of ``platforms`` (default: the running ones) follows, when
        they all follow the same one and it is one of them (None otherwise). Which one it
        is depends on who started first: election is sticky."""
        group = list(platforms) if platforms is not None else self.running()
        masters = {self.status(p).get("master") for p in group}
        master = masters.pop() if len(masters) == 1 else None
        return master if isinstance(master, int) and master in group else None

    def wait(
        self,
        what: str,
        condition: Callable[[], bool],
        timeout: float = 20.0,
        detail: Callable[[], str] | None = None,
    ) -> float:
        """Wait until ``condition()``; returns the seconds it took. On timeout raises
        AssertionError naming ``what`` with ``detail()`` and the tail of every log."""
        start = time.monotonic()
        end = start + timeout
        while time.monotonic() < end:
            if condition():
                return time.monotonic() - start
            time.sleep(0.1)
        logs = "\n".join(
            f"--- {p.name}\n{p.read_text(errors='replace')[-1200:]}"
            for p in sorted(self.dir.glob("daemon-*.log"))
        )
        more = "" if detail is None else f" ({detail()})"
        raise AssertionError(f"timed out after {timeout} s waiting for {what}{more}\n{logs}")
