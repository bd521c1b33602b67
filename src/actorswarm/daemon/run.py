"""``actorswarm daemon``: one platform as a process, until SIGTERM or SIGINT.

Start-up: the state directory gives the incarnation of this start (one more than the last)
and the scripts deployed before; when the platform was running a script it rejoins it,
restoring the actors of its latest backup (or starting the initial ones). Then it serves:
heartbeats go out, the swarm is joined, the ground station's commands are obeyed. Every
second it writes ``status.json`` in the state directory (what ``gs status`` and the tests
read locally), and it logs one JSON object per line on stderr for the things an operator
wants to see: start, master changes, transitions, stop.

A signal stops it cleanly: the loop ends, the transport closes (the swarm notices the
platform leave within its failure-detection time) and the process exits 0.
"""

from __future__ import annotations

import asyncio
import json
import logging
import os
import signal
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from actorswarm.core.config import CoreConfig
from actorswarm.daemon.endpoint import PlatformEndpoint
from actorswarm.daemon.loop import clock, serve
from actorswarm.daemon.state import StateDir
from actorswarm.security.guard import PacketGuard
from actorswarm.transport.zenoh_transport import ZenohSettings, ZenohTransport

__all__ = ["DaemonOptions", "run_daemon"]

log = logging.getLogger("actorswarm.daemon")


@dataclass(frozen=True, slots=True)
class DaemonOptions:
    platform: int
    swarm: str
    state_dir: Path
    zenoh: ZenohSettings = field(default_factory=ZenohSettings)
    config: CoreConfig = field(default_factory=CoreConfig)
    #: The packet guard (``PacketGuard.insecure()`` only with ``--insecure``).
    guard: PacketGuard = field(default_factory=PacketGuard.insecure)


def _log(event: str, **fields: Any) -> None:
    # ``t`` is the host's monotonic clock, the same clock as the transitions' times in
    # status.json: lines of several daemons on one machine can be compared.
    log.info(json.dumps({"t": round(clock(), 6), "event": event, **fields}, default=str))


def _write_status(path: Path, endpoint: PlatformEndpoint, now: float, guard: PacketGuard) -> None:
    node, engine = endpoint.node, endpoint.engine
    status = {
        "platform": node.platform,
        "incarnation": node.incarnation,
        "master": node.master,
        "is_master": node.is_master,
        "epoch": node.epoch,
        "members": sorted(node.members.peers),
        "actors": list(endpoint.runtime.running()),
        "script": engine.script_sha,
        "transitions": [
            {"t": r.t, "from": r.src, "to": r.dst, "event": r.event, "cause": r.cause}
            for r in engine.transitions[-200:]
        ],
        "secure": guard.secure,
        "accepted": guard.accepted,
        "rejected": dict(guard.rejected),
        "dropped": dict(node.counters),
        "pid": os.getpid(),
        "t": now,
    }
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(status))
    partial.replace(path)


async def _main(options: DaemonOptions) -> int:
    state = StateDir(options.state_dir)
    incarnation = state.next_incarnation()
    now = clock()
    endpoint = PlatformEndpoint(
        options.platform,
        swarm=options.swarm,
        incarnation=incarnation,
        now=now,
        config=options.config,
        store=state.backups,
        seed=options.platform,
    )
    engine = endpoint.engine

    def deployed(sha: str, text: bytes) -> None:
        state.save_script(text)
        _log("deployed", script=sha[:12])

    engine.on_deployed = deployed
    engine.on_started = state.set_running
    running = state.running()
    if running is not None:
        kept = state.script(running)
        if kept is None:
            _log("rejoin-failed", why=f"script {running[:12]} missing from the state directory")
        else:
            engine.adopt(kept)
            resumed = engine.rejoin(running, now)
            _log("rejoined", script=running[:12], resumed=resumed)
    loop = asyncio.get_running_loop()
    inbox: asyncio.Queue[bytes] = asyncio.Queue()
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)

    def arrived(data: bytes) -> None:  # on a Zenoh thread: hand over, nothing else
        loop.call_soon_threadsafe(inbox.put_nowait, data)

    transport = ZenohTransport(options.swarm, options.platform, arrived, options.zenoh)
    _log(
        "started",
        platform=options.platform,
        swarm=options.swarm,
        incarnation=incarnation,
        secure=options.guard.secure,
    )
    status_file = options.state_dir / "status.json"
    last = {"status": 0.0, "master": None, "transitions": 0}

    def on_wake(t: float) -> None:
        if endpoint.node.master != last["master"]:
            last["master"] = endpoint.node.master
            _log("master", master=endpoint.node.master, epoch=endpoint.node.epoch)
        records = engine.transitions
        for r in records[int(last["transitions"] or 0) :]:
            _log("transition", at=r.t, frm=r.src, to=r.dst, on=r.event, cause=r.cause)
        last["transitions"] = len(records)
        if t - float(last["status"] or 0.0) >= 1.0:
            last["status"] = t
            _write_status(status_file, endpoint, t, options.guard)

    try:
        with transport:
            await serve(endpoint, transport, inbox, stop, on_wake=on_wake, guard=options.guard)
    finally:
        _write_status(status_file, endpoint, clock(), options.guard)
        _log("stopped", platform=options.platform)
    return 0


def run_daemon(options: DaemonOptions) -> int:
    """Run the daemon until a signal; returns the exit status."""
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    return asyncio.run(_main(options))
