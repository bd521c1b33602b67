"""A command called in-process from a thread that already runs an event loop (an
application, a notebook, a browser test's Playwright in the same worker) behaves as from a
shell: ``asyncio.run`` would refuse to start there, so the ground station's commands run
their link in a thread of its own (``cli.common.run_async``)."""

from __future__ import annotations

import asyncio
import socket

from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.cli.common import run_async


def test_run_async_runs_a_coroutine_with_or_without_a_running_loop() -> None:
    async def answer() -> int:
        await asyncio.sleep(0)
        return 42

    assert run_async(answer()) == 42

    async def inside() -> int:
        return run_async(answer())

    assert asyncio.run(inside()) == 42


def test_a_busy_port_is_one_line_and_exit_2_inside_a_running_loop() -> None:
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen(1)
    port = busy.getsockname()[1]
    args = ["gs", "status", "--swarm", "loop", "--no-multicast", "--listen",
            f"tcp/127.0.0.1:{port}", "--timeout", "1"]  # fmt: skip

    async def invoke() -> object:
        return CliRunner().invoke(app, args)

    try:
        result = asyncio.run(invoke())
    finally:
        busy.close()
    output = getattr(result, "output", "")
    assert "Traceback" not in output and "running event loop" not in output, output
    assert getattr(result, "exit_code", None) == 2, output
