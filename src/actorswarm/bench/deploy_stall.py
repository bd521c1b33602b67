"""How long a deploy holds up a daemon's event loop (docs/benchmarks/README.md, "A deploy
and the daemon's loop").

A deployed script is checked by a child interpreter (:mod:`actorswarm.dsl.isolated`) while
the daemon's loop goes on serving: heartbeats, acknowledgements and the vehicle's steps are
never held up by the checker. :func:`deploy_beside_probe` shows it on a real daemon run in
this process, on its own event loop: a probe task sleeps :data:`TICK` seconds over and
over and records how late each wake-up came (the loop's *stall*), while a ground station
(``actorswarm gs deploy``, another process) deploys a script to the daemon over Zenoh on
loopback. The daemon's check is wrapped to record when it began and ended.

What a run gives (:class:`DeployStall`): the ground station's exit status and output, each
check's span, every wake-up of the probe while the deploy was in progress, and from those
the longest stall and the wake-ups that came *during* the check. A check made on the loop
would leave no wake-up inside its span, and a stall as long as the whole check; a check in
a child leaves wake-ups all along it. The stall's length depends on the machine's load, so
it is a benchmark figure (``scripts/deploy_stall.py``), not a test's bound.

The daemon's run ends with a SIGTERM this process sends itself, which the daemon's own
handler turns into a clean stop: call :func:`deploy_beside_probe` from a main thread, one
at a time.
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import time
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from unittest.mock import patch

from actorswarm.daemon import run as daemon_run
from actorswarm.daemon.launch import free_ports
from actorswarm.daemon.run import DaemonOptions
from actorswarm.dsl.isolated import CHECK_TIMEOUT, check_isolated_async
from actorswarm.dsl.model import TaskScript
from actorswarm.transport.zenoh_transport import ZenohSettings

__all__ = ["TICK", "DeployStall", "deploy_beside_probe"]

#: The probe's sleep, seconds: each wake-up later than this is the loop's stall.
TICK = 0.005


@dataclass(slots=True)
class DeployStall:
    """One deploy beside the probe. Times are ``time.perf_counter`` seconds."""

    #: The ground station's exit status and what it printed.
    code: int = -1
    output: str = ""
    #: Each check of the deployed script: (began, ended).
    checks: list[tuple[float, float]] = field(default_factory=list)
    #: Each wake-up of the probe while the deploy was in progress: (when, how late).
    wakes: list[tuple[float, float]] = field(default_factory=list)

    @property
    def worst(self) -> float:
        """The longest stall of the loop while the deploy was in progress, seconds."""
        return max((late for _, late in self.wakes), default=0.0)

    @property
    def check_s(self) -> float:
        """How long the (first) check took, seconds (0 when there was none)."""
        return self.checks[0][1] - self.checks[0][0] if self.checks else 0.0

    def wakes_during_check(self) -> int:
        """The probe's wake-ups strictly inside the first check's span."""
        if not self.checks:
            return 0
        began, ended = self.checks[0]
        return sum(1 for when, _ in self.wakes if began < when < ended)


#: How the daemon checks a deployed script: :func:`~actorswarm.dsl.isolated.check_isolated_async`.
Check = Callable[..., Awaitable[TaskScript]]


@contextmanager
def _timed_checks(record: list[tuple[float, float]], check: Check) -> Iterator[None]:
    """Have the daemon check scripts with ``check``, each call's span landing in ``record``."""

    async def timed(text: str, path: str, *, timeout: float = CHECK_TIMEOUT) -> TaskScript:
        began = time.perf_counter()
        try:
            return await check(text, path, timeout=timeout)
        finally:
            record.append((began, time.perf_counter()))

    with patch.object(daemon_run, "check_isolated_async", timed):
        yield


def deploy_beside_probe(
    script: Path,
    state_dir: Path,
    *,
    timeout: float = 10.0,
    check: Check = check_isolated_async,
) -> DeployStall:
    """Run a daemon (platform 1, insecure, on a free loopback port, state in ``state_dir``)
    beside the probe; deploy ``script`` to it with ``gs deploy``; stop the daemon. The
    daemon's exit status must be 0 (AssertionError otherwise); the ground station's is in
    the result. ``check``: how the daemon checks the script (another one for comparison,
    e.g. one that checks on the loop)."""
    (port,) = free_ports(1)
    endpoint = f"tcp/127.0.0.1:{port}"
    options = DaemonOptions(
        platform=1,
        swarm=f"stall{os.getpid()}",
        state_dir=state_dir,
        zenoh=ZenohSettings(listen=(endpoint,), multicast=False),
    )
    result = DeployStall()
    measuring = [False]

    async def probe() -> None:
        loop = asyncio.get_running_loop()
        while True:
            before = loop.time()
            await asyncio.sleep(TICK)
            if measuring[0]:
                result.wakes.append((time.perf_counter(), loop.time() - before - TICK))

    async def deploy() -> None:
        await asyncio.sleep(1.0)  # the daemon up and listening
        gs = await asyncio.create_subprocess_exec(
            *[sys.executable, "-m", "actorswarm", "gs", "deploy", str(script)],
            *["--expect", "1", "--swarm", options.swarm, "--insecure", "--no-multicast"],
            *["--connect", endpoint, "--timeout", str(timeout)],
            *["--state", str(state_dir.parent / f"{state_dir.name}-gs.json")],
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        measuring[0] = True
        out, _ = await gs.communicate()
        measuring[0] = False
        result.code, result.output = gs.returncode or 0, out.decode()
        os.kill(os.getpid(), signal.SIGTERM)  # the daemon's own handler stops it cleanly

    async def together() -> None:
        loop = asyncio.get_running_loop()
        watcher = loop.create_task(probe())
        daemon = loop.create_task(daemon_run._main(options))
        await deploy()
        code = await asyncio.wait_for(daemon, timeout)
        watcher.cancel()
        assert code == 0, f"the daemon exited with {code}"

    with _timed_checks(result.checks, check):
        asyncio.run(together())
    return result
