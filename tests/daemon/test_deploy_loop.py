"""A deploy never blocks the daemon's loop: the script is checked by a child process while
the loop goes on serving. A real daemon runs in this process, next to a probe that measures
the loop's longest stall; a ground station (``actorswarm gs deploy``, another process)
deploys a script to it over Zenoh on loopback."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.daemon import run as daemon_run
from actorswarm.daemon.launch import free_ports
from actorswarm.daemon.run import DaemonOptions, _main
from actorswarm.transport.zenoh_transport import ZenohSettings

SCRIPT = Path(__file__).with_name("three.xml")
TICK = 0.005


def test_the_loop_keeps_serving_while_a_deployed_script_is_checked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (port,) = free_ports(1)
    endpoint = f"tcp/127.0.0.1:{port}"
    options = DaemonOptions(
        platform=1,
        swarm=f"lag{os.getpid()}",
        state_dir=tmp_path / "state",
        zenoh=ZenohSettings(listen=(endpoint,), multicast=False),
    )
    checks: list[float] = []
    real_check = daemon_run.check_isolated_async

    async def timed_check(text: str, path: str) -> Any:
        began = time.perf_counter()
        try:
            return await real_check(text, path)
        finally:
            checks.append(time.perf_counter() - began)

    monkeypatch.setattr(daemon_run, "check_isolated_async", timed_check)
    stalls: list[float] = []
    measuring = [False]

    async def probe() -> None:
        loop = asyncio.get_running_loop()
        while True:
            before = loop.time()
            await asyncio.sleep(TICK)
            if measuring[0]:
                stalls.append(loop.time() - before - TICK)

    async def deploy() -> tuple[int, str]:
        await asyncio.sleep(1.0)  # the daemon up and listening
        gs = await asyncio.create_subprocess_exec(
            *[sys.executable, "-m", "actorswarm", "gs", "deploy", str(SCRIPT)],
            *["--expect", "1", "--swarm", options.swarm, "--insecure", "--no-multicast"],
            *["--connect", endpoint, "--timeout", "10", "--state", str(tmp_path / "gs.json")],
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.STDOUT,
        )
        measuring[0] = True
        out, _ = await gs.communicate()
        measuring[0] = False
        os.kill(os.getpid(), signal.SIGTERM)  # the daemon's own handler stops it cleanly
        return gs.returncode or 0, out.decode()

    async def together() -> tuple[int, str]:
        watcher = asyncio.get_running_loop().create_task(probe())
        daemon = asyncio.get_running_loop().create_task(_main(options))
        code, out = await deploy()
        assert await asyncio.wait_for(daemon, 10) == 0
        watcher.cancel()
        return code, out

    code, out = asyncio.run(together())
    assert code == 0, out
    assert "confirmed by 1 of 1" in out, out
    assert len(checks) == 1, "the deployed script was checked once, in a child"
    worst = max(stalls)
    leave = CoreConfig().t_leave
    # Checked on the loop, the stall would be the whole check (a child interpreter's
    # start-up, 0.2 s on an idle machine): the loop must stay far below both.
    assert worst < min(checks[0] / 2, leave / 4), (
        f"the loop stalled {worst * 1000:.0f} ms during a deploy whose check took "
        f"{checks[0] * 1000:.0f} ms (failure detection: {leave * 1000:.0f} ms)"
    )
