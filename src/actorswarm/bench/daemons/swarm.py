"""Orchestration of one swarm of real daemons: whether it agreed, waiting until it does,
why it does not, and the ground station and environment the bench drives it with."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from actorswarm.daemon.loop import clock

if TYPE_CHECKING:
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.daemon.launch import LocalSwarm


def settled(swarm: LocalSwarm) -> bool:
    """Every running daemon's status was written by the process running now, has every
    other running one in its view, and they all follow the same master. (A daemon rewrites
    its status within a second of a change, and not when nothing changed: the status of a
    running daemon is current however old it is.)"""
    running = swarm.running()
    if len(running) != swarm.size:
        return False
    for p in running:
        status = swarm.status(p)
        if status.get("pid") != swarm.procs[p].pid:
            return False
        if len(status.get("members", ())) != swarm.size - 1:
            return False
    return swarm.agreed_master(running) is not None


def describe_swarm(swarm: LocalSwarm) -> str:
    """A swarm that does not settle, in a line: views, masters, epochs, master changes."""
    statuses = [swarm.status(p) for p in swarm.running()]
    views = [len(st.get("members", ())) for st in statuses]
    masters: dict[str, int] = {}
    for st in statuses:
        key = str(st.get("master"))
        masters[key] = masters.get(key, 0) + 1
    epochs = [int(st.get("epoch", 0)) for st in statuses]
    changes = sum(
        1
        for p in swarm.running()
        for line in swarm.log(p).read_text(errors="replace").splitlines()
        if '"event": "master"' in line
    )
    return (
        f"{len(statuses)} daemons running, views of {min(views, default=0)}–"
        f"{max(views, default=0)} peers (of {swarm.size - 1}), following "
        + ", ".join(f"{k} ({v})" for k, v in sorted(masters.items()))
        + f"; epochs up to {max(epochs, default=0)}, {changes} master changes logged"
    )


def _picture(swarm: LocalSwarm) -> tuple[int | None, tuple[int, ...]]:
    """The agreed master and every running daemon's epoch, to tell a steady swarm."""
    epochs = tuple(int(swarm.status(p).get("epoch", -1)) for p in swarm.running())
    return swarm.agreed_master(), epochs


def wait_stable(swarm: LocalSwarm, timeout: float, hold: float = 1.5) -> bool:
    """Wait until the swarm is :func:`settled` and stays so, with the same master and
    epochs, for ``hold`` seconds (longer than the second within which a daemon writes a
    change to its status, so a change under way shows). A swarm that merely passes through
    agreement — a restarted platform that is about to take the role over — does not
    count."""
    end = clock() + timeout
    while clock() < end:
        if not settled(swarm):
            time.sleep(0.2)
            continue
        seen = _picture(swarm)
        time.sleep(hold)
        if settled(swarm) and _picture(swarm) == seen:
            return True
    return False


def wait(condition: Callable[[], bool], timeout: float, poll: float = 0.05) -> bool:
    """Poll ``condition`` until it holds (True) or ``timeout`` seconds pass (False)."""
    end = clock() + timeout
    while not condition():
        if clock() >= end:
            return False
        time.sleep(poll)
    return True


def ground_session(swarm: LocalSwarm, lease: float | None = None) -> GroundSession:
    """A ground station for ``swarm`` in this process (enter it in a running event loop),
    connected to every daemon (or on its multicast group), with the swarm's keys when it is
    secure, and Zenoh's lease ``lease`` seconds (None: the default)."""
    from actorswarm.daemon.ground import GroundSession
    from actorswarm.security import PacketGuard, load_keys
    from actorswarm.transport.zenoh_transport import LEASE_MS, ZenohSettings

    lease_ms = LEASE_MS if lease is None else round(lease * 1000)
    guard = (
        PacketGuard.from_keys(load_keys(swarm.keys, need_private=True), role="ground")
        if swarm.secure
        else PacketGuard.insecure()
    )
    if swarm.group is not None:
        zenoh = ZenohSettings(
            multicast=False,
            broadcast="multicast",
            group=swarm.group,
            interface=swarm.interface,
            lease_ms=lease_ms,
        )
    else:
        zenoh = ZenohSettings(connect=tuple(swarm.endpoints), multicast=False, lease_ms=lease_ms)
    return GroundSession(swarm.swarm, zenoh, guard)


async def deploy(
    gs: GroundSession,
    swarm: LocalSwarm,
    script: str,
    name: str,
    ready: Callable[[list[str]], bool],
    timeout: float,
) -> str:
    """Deploy ``script`` to every platform from ``gs`` and start it (a new version replaces
    the one running; a copy is kept as ``name``.xml in the swarm's directory); wait until
    every platform acknowledged the start and runs it with actors ``ready`` accepts. "" or
    why not."""
    everyone = list(range(1, swarm.size + 1))
    data = script.encode()
    (swarm.dir / f"{name}.xml").write_bytes(data)
    sha = gs.do(lambda st, now: st.deploy(data, everyone, now))
    if not await gs.wait_for(lambda: not gs.station.missing(sha), timeout):
        return f"deploy {name}: not confirmed by platforms {gs.station.missing(sha)}"
    gs.do(lambda st, now: st.start(now))

    def running() -> bool:
        if not set(everyone) <= set(gs.station.outcomes("Start")):
            return False
        statuses = [swarm.status(p) for p in everyone]
        return all(st.get("script") == sha and ready(list(st.get("actors", []))) for st in statuses)

    if await gs.wait_for(running, timeout):
        return ""
    statuses = {p: swarm.status(p) for p in everyone}
    where = {p: (str(st.get("script", ""))[:12], st.get("actors")) for p, st in statuses.items()}
    return f"start {name}: not every platform runs it (script, actors): {where}"


def daemons_env(checkout: str | Path) -> dict[str, str]:
    """The environment that makes a daemon run the source of ``checkout`` (its ``src`` first
    on ``PYTHONPATH``); ValueError when ``checkout`` holds no actorswarm source."""
    src = Path(checkout).resolve() / "src"
    if not (src / "actorswarm" / "__init__.py").is_file():
        raise ValueError(f"--daemons-from {checkout}: no actorswarm source in {src}")
    return {**os.environ, "PYTHONPATH": str(src)}
