"""``actorswarm daemon``: one platform as a process, until SIGTERM or SIGINT.

Start-up: the state directory gives the incarnation of this start (one more than the last)
and the scripts deployed before; when the platform was running a script it rejoins it,
restoring the actors of its latest backup (or starting the initial ones). A backup is
taken after every transition and when the operator asks (``gs backup``), and on a clean
stop when the actors' state changed since the last one, so a daemon killed in the middle
of a mission comes back in the actors it was running, with their plugins' state as of the
last backup. Then it serves: heartbeats go out, the swarm is joined, the ground station's
commands are obeyed. It keeps ``status.json`` in the state directory (what the tests and
an operator on the robot read) and logs one JSON object per line on stderr for the things
an operator wants to see: start, master changes, transitions, stop.

Files are written only when what they say changed
(:class:`~actorswarm.daemon.state.WritePacer`): ``status.json`` within a second of a change
of the platform's state (master, members, actors, transitions, packets rejected...), but
when only the packet counters moved (``traffic``, ``accepted``, ``dropped``, ``receive``,
``ros2``) at most every :data:`_METERS_EVERY` seconds; its ``t`` is when it was written. The
replay windows are saved at most every :data:`_REPLAY_EVERY` seconds, when a packet was
accepted since. A platform alone rewrites only its status, every :data:`_METERS_EVERY`
seconds (the heartbeats it sent).

``receive`` counts how packets were taken in: ``batches`` (wakes that took packets),
``packets``, ``largest_batch``, ``cut_batches`` (batches cut at
:data:`~actorswarm.daemon.loop.BATCH_LIMIT`), ``bursts`` (wake-ups Zenoh's receive channels
asked for) and ``ring_full`` (drains that found a receive channel full: packets were
probably lost), see :mod:`actorswarm.transport.zenoh_transport`.

The lines a benchmark reads (``t`` is when the line was written; ``at`` the loop's time
when the thing happened; ``traffic`` the cumulative ``[sent packets, sent bytes, received
packets, received bytes]`` on the wire, :class:`~actorswarm.daemon.loop.Traffic`):

* ``command``: an operator command carried out (``command``, ``on``: the event of an
  ``Inject``, ``ok``); ``traffic`` as it was when that wake began, before the command's
  packet was taken in.
* ``transition``: a switch (``frm``, ``to``, ``on``, ``cause``); ``traffic`` after the wake's
  packets went out.
* ``fired`` (master only): it released a transition group (``key``, ``generation``,
  ``outcome``, ``chosen``); ``traffic`` after the wake's packets went out.
* ``switched``: the single Actor switch time of a switch to ``actor`` (from ``frm``):
  ``took_ms`` from the switch call to the end of the new actor's first OODA step.

And for the operator (:mod:`actorswarm.daemon.records`; the engine keeps none of these, so a
daemon that runs for months does not grow): ``ignored``, an event the current actor has no
transition for (``on``, ``why``), and ``plugin-failed``, a plugin that raised (``actor``,
``plugin``, ``error``; its actor is in ``error``). ``status.json`` shows the last
:data:`~actorswarm.daemon.records.STATUS_TRANSITIONS` transitions; the log has them all.

With ``--vehicle mavlink`` the daemon flies a PX4 or ArduPilot autopilot
(:class:`~actorswarm.vehicles.mavlink.vehicle.MavlinkVehicle`, served by its own thread):
``status.json`` carries its ``vehicle`` state (link, autopilot, mode, armed, the plan in
progress), a lost or restored link becomes the local event ``vehicle_link_lost`` /
``vehicle_link_restored`` of the task script (logged as ``vehicle-event`` with its
``name``), and whatever the autopilot refused or never answered is logged as
``vehicle-error``; a command that failed for good also raises the local event
``vehicle_fault_event`` (data ``{"reason": ...}``, logged as ``vehicle-fault``). The
operator's events ``vehicle_land`` and ``vehicle_hold`` (``gs event``)
land or hold the vehicle and keep the plugins' commands from it until ``vehicle_resume``
(logged as ``vehicle-override``).

With ``--ros2`` (or ``--vehicle ros2``) the daemon owns one ROS 2 node
(:mod:`actorswarm.ros2.platform`) that its plugins reach as ``ctx.ros2``; the node's errors
are logged as ``ros2-error``, and a node that cannot be made as ``ros2-failed`` — the daemon
then runs on without ROS 2, unless its vehicle is the ROS 2 one (exit status 1).
``status.json``'s ``ros2`` says what the node's subscriptions received, dropped (a topic
that floods) and could not decode, and how many errors it reported.

A signal stops it cleanly: the loop ends, the transport closes (the swarm notices the
platform leave within its failure-detection time) and the process exits 0. The stop waits
for Zenoh's close for ``CLOSE_WAIT_S`` (0.5 s) at most: over a lossy radio its goodbyes
to the peers take seconds, and the process leaves meanwhile.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import signal
import sys
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from actorswarm.core.config import CoreConfig
from actorswarm.core.node import Outgoing
from actorswarm.daemon.endpoint import PlatformEndpoint
from actorswarm.daemon.flap import FLAP_CHECK_S, FlapWatch
from actorswarm.daemon.heap import HeapTrim
from actorswarm.daemon.loop import Inbox, Traffic, clock, serve
from actorswarm.daemon.prefetch import prefetch
from actorswarm.daemon.records import STATUS_TRANSITIONS, EngineRecords
from actorswarm.daemon.state import StateDir, WritePacer
from actorswarm.dsl.isolated import ScriptRefused, check_isolated, check_isolated_async
from actorswarm.runtime.context import VEHICLE_FAULT_EVENT
from actorswarm.security.guard import PacketGuard
from actorswarm.security.pipeline import Pipeline
from actorswarm.transport.zenoh_transport import CLOSE_WAIT_S, ZenohSettings, ZenohTransport

if TYPE_CHECKING:
    from actorswarm.dsl.model import TaskScript
    from actorswarm.engine.engine import TaskEngine
    from actorswarm.engine.records import TransitionRecord
    from actorswarm.ros2.daemon import Ros2Options
    from actorswarm.ros2.vehicle import Ros2Vehicle
    from actorswarm.vehicles.mavlink.vehicle import MavlinkVehicle
    from actorswarm.world.config import WorldConfig

__all__ = ["DaemonFiles", "DaemonOptions", "run_daemon"]


#: Seconds between two saves of the replay windows (and at a clean stop), when they changed.
#: After a crash, packets of the last interval could be replayed once; each save is a file
#: write.
_REPLAY_EVERY = 5.0
#: ``status.json``: a changed state is written within this many seconds.
_STATUS_EVERY = 1.0
#: ``status.json``: when only the packet counters moved, rewritten at most this often.
_METERS_EVERY = 10.0


@dataclass(frozen=True, slots=True)
class DaemonOptions:
    platform: int
    swarm: str
    state_dir: Path
    zenoh: ZenohSettings = field(default_factory=ZenohSettings)
    config: CoreConfig = field(default_factory=CoreConfig)
    #: The packet guard (``PacketGuard.insecure()`` only with ``--insecure``).
    guard: PacketGuard = field(default_factory=PacketGuard.insecure)
    #: ``--vehicle sim``: the world of the simulated vehicle this daemon flies (None: no
    #: vehicle; actors whose plugins need one are refused, as on a robot without one).
    world: WorldConfig | None = None
    #: ``--vehicle mavlink``: the autopilot this daemon flies, its connection open (None:
    #: none). The daemon starts its thread and closes it at the stop.
    autopilot: MavlinkVehicle | None = None
    #: ``--ros2`` / ``--vehicle ros2``: the platform's ROS 2 node (and vehicle) to open once
    #: the loop runs (None: no ROS 2).
    ros2: Ros2Options | None = None


@dataclass(slots=True)
class _Seen:
    """What the daemon's loop already reported: the master it logged, whether it said it
    heard nobody on its multicast group (:data:`ALONE_S`), and when it last looked for
    flapping links."""

    master: int | None = None
    alone_said: bool = False
    #: When the loop next looks for platforms whose links come and go (:mod:`.flap`).
    flaps_next: float = 0.0


#: Seconds a daemon on a multicast group may hear no packet at all before it says so: a
#: network that drops multicast silently (many Wi-Fi access points) looks just like this.
ALONE_S = 10.0


def _log(event: str, **fields: Any) -> None:
    # ``t`` is the host's monotonic clock, the same clock as the transitions' times in
    # status.json: lines of several daemons on one machine can be compared. Written
    # straight to stderr, one line at a time, not through ``logging``: a daemon writes two
    # or three lines per switch, and the logging module's record and handler were a tenth
    # of a member's Python time during a run of collective switches.
    # A line that cannot be written (stderr closed, its reader gone) is lost, as the
    # logging module would lose it; the daemon goes on.
    line = json.dumps({"t": round(clock(), 6), "event": event, **fields}, default=str)
    with contextlib.suppress(OSError, ValueError):
        sys.stderr.write(line + "\n")


def _status(
    endpoint: PlatformEndpoint,
    guard: PacketGuard,
    traffic: Traffic,
    autopilot: MavlinkVehicle | Ros2Vehicle | None = None,
    receive: Callable[[], dict[str, int]] | None = None,
    transitions: Iterable[TransitionRecord] | None = None,
    ros2: Callable[[], dict[str, Any]] | None = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """What ``status.json`` says: the platform's state, and the packet counters that move
    all the time (written less often when nothing else changed), the ROS 2 node's among
    them (``ros2``: its topics' counters, :meth:`~actorswarm.ros2.platform.PlatformRos.
    status`)."""
    node, engine = endpoint.node, endpoint.engine
    state = {
        "platform": node.platform,
        "incarnation": node.incarnation,
        "master": node.master,
        "is_master": node.is_master,
        "epoch": node.epoch,
        # The swarm as this platform sees it (a star member: its master's roster).
        "members": [p for p in node.view if p != node.platform],
        "membership": node.config.membership,
        "actors": list(endpoint.runtime.running()),
        "loaded": endpoint.runtime.loaded(),
        "script": engine.script_sha,
        # When the task began on the shared clock (UTC seconds; None: not started).
        "began": engine.began,
        "transitions": [
            {"t": r.t, "from": r.src, "to": r.dst, "event": r.event, "cause": r.cause}
            for r in (
                engine.transitions[-STATUS_TRANSITIONS:] if transitions is None else transitions
            )
        ],
        "secure": guard.secure,
        "rejected": dict(guard.rejected),
        "position": endpoint.runtime.position(),
        "pid": os.getpid(),
    }
    if autopilot is not None:
        state["vehicle"] = autopilot.status()
    meters = {
        "accepted": guard.accepted,
        "dropped": dict(node.counters),
        "traffic": traffic.as_dict(),
    }
    if receive is not None:
        meters["receive"] = receive()
    if ros2 is not None:
        meters["ros2"] = ros2()
    return state, meters


def _write_status(path: Path, state: dict[str, Any], meters: dict[str, Any], now: float) -> None:
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps({**state, **meters, "t": now}))
    partial.replace(path)


class DaemonFiles:
    """The files a running daemon rewrites, ``status.json`` and the replay windows, each
    written when what it says changed (:class:`~actorswarm.daemon.state.WritePacer`). Made
    once the replay windows of the last life are restored into ``guard``: they are on disk
    already."""

    def __init__(
        self,
        state: StateDir,
        endpoint: PlatformEndpoint,
        guard: PacketGuard,
        traffic: Traffic,
        autopilot: MavlinkVehicle | Ros2Vehicle | None = None,
        *,
        receive: Callable[[], dict[str, int]] | None = None,
        transitions: Iterable[TransitionRecord] | None = None,
        ros2: Callable[[], dict[str, Any]] | None = None,
    ) -> None:
        self.state = state
        self.status_file = state.path / "status.json"
        self.endpoint = endpoint
        self.guard = guard
        self.traffic = traffic
        self.autopilot = autopilot
        self.receive = receive
        #: The transitions status.json shows (None: the engine's last ones).
        self.transitions = transitions
        #: What status.json says of the ROS 2 node (None: the daemon has none).
        self.ros2 = ros2
        self.status = WritePacer(_STATUS_EVERY, _METERS_EVERY)
        self.replay = WritePacer(_REPLAY_EVERY, seen=guard.replay_snapshot())

    def wake(self, now: float) -> None:
        """After a wake of the loop: look at what is due (building the status costs, so at
        most once per period), write what changed."""
        if self.status.due(now):
            self._save_status(now)
        if self.replay.due(now):
            self._save_replay(now)

    def close(self, now: float) -> None:
        """At a clean stop: write whatever differs from what was last written."""
        self._save_status(now, closing=True)
        self._save_replay(now, closing=True)

    def _save_status(self, now: float, *, closing: bool = False) -> None:
        content, meters = _status(
            self.endpoint,
            self.guard,
            self.traffic,
            self.autopilot,
            self.receive,
            self.transitions,
            self.ros2,
        )
        if self.status.changed(now, content, meters, closing=closing):
            _write_status(self.status_file, content, meters, now)

    def _save_replay(self, now: float, *, closing: bool = False) -> None:
        windows = self.guard.replay_snapshot()
        if self.replay.changed(now, windows, closing=closing):
            self.state.save_replay_windows(windows)


async def _main(options: DaemonOptions) -> int:
    state = StateDir(options.state_dir)
    incarnation = state.next_incarnation()
    guard = options.guard
    # The replay windows of the last life: packets recorded before a crash are still
    # replays after it (up to the last _REPLAY_EVERY seconds before a crash).
    guard.restore_replay(state.replay_windows(), clock())
    now = start = clock()
    world = None
    if options.world is not None:
        from actorswarm.world.world import World  # NumPy: only with a simulated vehicle

        world = World(options.world, [options.platform])
    autopilot: MavlinkVehicle | Ros2Vehicle | None = options.autopilot
    ros = None
    if options.ros2 is not None:
        from actorswarm.ros2 import Ros2Error
        from actorswarm.ros2.daemon import open_ros

        try:
            ros, ros_vehicle = open_ros(
                options.ros2, options.platform, options.swarm, asyncio.get_running_loop()
            )
        except Ros2Error as exc:
            _log("ros2-failed", error=str(exc))
            if options.ros2.vehicle is not None:
                return 1  # no vehicle to fly
        else:
            autopilot = ros_vehicle or autopilot
    if autopilot is not None:
        autopilot.start()
    endpoint = PlatformEndpoint(
        options.platform,
        swarm=options.swarm,
        incarnation=incarnation,
        now=now,
        config=options.config,
        store=state.backups,
        vehicle=autopilot if world is None else world.vehicle(options.platform),
        camera=None if world is None else world.camera(options.platform),
        areas=None if world is None else world.area_polygons(),
        seed=options.platform,
    )
    engine = endpoint.engine

    # Freed heap back to the system after the start-up and after each deploy and start
    # (the checker's and the plugins' one-off garbage): about 1 MiB of RssAnon each time.
    heap = HeapTrim()

    def deployed(sha: str, text: bytes) -> None:
        state.save_script(text)
        heap.due()
        _log("deployed", script=sha[:12])

    def started(sha: str) -> None:
        state.set_running(sha, engine.began)
        heap.due()

    engine.on_deployed = deployed
    engine.on_started = started
    # The task's start comes on the swarm's shared clock (UTC, kept by GPS or NTP on a
    # robot); the engine's own clock is monotonic.
    engine.clock_offset = lambda: time.time() - clock()
    # Scripts are checked in a child process: the daemon never carries the checker.
    engine.checker = check_isolated
    running = state.running()
    if running is not None:
        kept = state.script(running)
        if kept is None:
            _log("rejoin-failed", why=f"script {running[:12]} missing from the state directory")
        else:
            engine.adopt(kept)
            resumed = engine.rejoin(running, now, began=state.began())
            _log("rejoined", script=running[:12], resumed=resumed)
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)

    transport = ZenohTransport(options.swarm, options.platform, options.zenoh)
    inbox = Inbox(loop, transport)
    # A deployed script is checked by a child process while the loop goes on serving: a
    # check on the loop (0.2 s idle, over 1 s on a loaded host) would silence the platform
    # long enough for the swarm to think it gone.
    engine.check_later = _check_later(engine, inbox)
    _log(
        "started",
        platform=options.platform,
        swarm=options.swarm,
        incarnation=incarnation,
        secure=guard.secure,
        vehicle="sim"
        if world is not None
        else "none"
        if autopilot is None
        else "mavlink"
        if options.ros2 is None or options.ros2.vehicle is None
        else "ros2",
        ros2=None if ros is None else ros.node.name,
        position=endpoint.runtime.position(),
        # How broadcasts travel: "mesh", or the multicast group's Zenoh endpoint (the
        # transport's: a group chosen by default that could not be opened is the mesh).
        broadcast=transport.settings.described,
        fell_back=transport.fell_back,
        # Whether it forwards for the others (multi-hop).
        relay=options.zenoh.relay,
    )
    seen = _Seen()
    flaps = FlapWatch(options.platform)
    began = clock()
    traffic = Traffic()
    records = EngineRecords(engine, endpoint.runtime, _log)
    files = DaemonFiles(
        state,
        endpoint,
        guard,
        traffic,
        autopilot,
        receive=lambda: {**inbox.as_dict(), **transport.receive_counters()},
        transitions=records.recent,
        ros2=None if ros is None else ros.status,
    )
    raised = 0

    if ros is not None:
        endpoint.runtime.ros2 = ros
        ros.on_wake(inbox.poke)
        ros.start()

    # Sends what a wake's own work made (the engine's answer to a vehicle's events), sealed
    # and counted as the loop's packets are.
    out = Pipeline(endpoint, transport, guard, traffic)

    def on_wake(t: float) -> None:
        nonlocal raised
        made: list[Outgoing] = []
        if ros is not None:
            ros.pump()  # the messages that came, to the plugins' readers
            for error in ros.drain_errors():
                _log("ros2-error", error=error)
        if world is not None:
            # The simulated vehicle lives in this process's time: seconds since start.
            world.step_to(t - start)
        if autopilot is not None:
            for record, fields in autopilot.drain_log():
                _log(record, **fields)
            for error in autopilot.drain_errors():
                _log("vehicle-error", error=error)
            events = autopilot.drain_events()
            for event in events:
                raised += 1
                _log("vehicle-event", name=event)
                # A local event of this platform, as a plugin's would be.
                engine.inject(
                    event, t, occasion=f"vehicle.{options.platform}.{incarnation}:{raised}"
                )
            faults = autopilot.drain_faults()
            for fault in faults:
                raised += 1
                _log("vehicle-fault", reason=fault)
                # A command that failed for good: the script may branch on it.
                engine.inject(
                    VEHICLE_FAULT_EVENT,
                    t,
                    data={"reason": fault},
                    occasion=f"vehicle.{options.platform}.{incarnation}:{raised}",
                )
            if events or faults:
                endpoint.tick(t)
                # The engine reacts now; what it made leaves once this wake's records are
                # written (they count the traffic before it), and the loop wakes again at
                # once.
                made = endpoint.ready().packets
                inbox.poke()
        if (
            not seen.alone_said
            and transport.settings.broadcast == "multicast"
            and t - began >= ALONE_S
        ):
            seen.alone_said = True
            if traffic.recv_packets == 0:
                _log(
                    "alone",
                    group=transport.settings.group_endpoint,
                    seconds=ALONE_S,
                    why="no packet heard on the multicast group: if other platforms are up, "
                    "this network drops multicast (many Wi-Fi access points do) or they are "
                    "on another group, interface or --broadcast; give every platform and the "
                    "ground station --broadcast mesh with --listen/--connect "
                    "(docs/deploying.md, Network)",
                )
        if endpoint.node.master != seen.master:
            seen.master = endpoint.node.master
            _log("master", master=endpoint.node.master, epoch=endpoint.node.epoch)
        if t >= seen.flaps_next:
            seen.flaps_next = t + FLAP_CHECK_S
            node = endpoint.node
            members = [p for p in node.view if p != node.platform]
            for fields in flaps.observe(t, members, node.master):
                _log("flapping", **fields)
        if engine.commands:
            if autopilot is not None:
                _operator_override(autopilot, engine.commands)
            before = list(traffic.at_wake)
            for c in engine.commands:
                _log("command", at=c.t, command=c.command, on=c.event, ok=c.ok, traffic=before)
            engine.commands.clear()
        after = list(traffic.counters())
        if engine.fired:
            for f in engine.fired:
                _log(
                    "fired",
                    at=f.t,
                    key=f.key,
                    generation=f.generation,
                    outcome=f.outcome,
                    chosen=list(f.chosen),
                    traffic=after,
                )
            engine.fired.clear()
        switched = records.drain(after)
        for timing in endpoint.runtime.drain_switches():
            _log(
                "switched",
                at=timing.t,
                frm=timing.src,
                actor=timing.dst,
                took_ms=round(timing.seconds * 1000, 3),
            )
        if switched:
            # A crash from now on resumes these actors, not the ones before the switch.
            endpoint.backup()
        files.wake(t)
        heap.wake()
        out.send(made)

    try:
        try:
            # A platform's output is sent after every packet: its engine reacts to each
            # packet before the next (PlatformEndpoint).
            await serve(
                endpoint,
                transport,
                inbox,
                stop,
                on_wake=on_wake,
                guard=guard,
                traffic=traffic,
                flush_each=True,
            )
        finally:
            # Zenoh's close waits for every peer's goodbye: seconds over a lossy radio, 10 s
            # when it gives up. The swarm tells a platform gone by its heartbeats, not by
            # that goodbye, so the stop goes on meanwhile, and the process leaves without
            # waiting for the rest (``closing``, the CLI's exit).
            transport.close(wait=CLOSE_WAIT_S)
    finally:
        # A clean stop resumes where it stopped (nothing written if the last backup says it).
        generation = endpoint.backup(changed_only=True)
        files.close(clock())
        if autopilot is not None:
            autopilot.close()
        if ros is not None:
            ros.close()
        _log("stopped", platform=options.platform, backup=generation)
    return 0


def _check_later(engine: TaskEngine, inbox: Inbox) -> Callable[[str, str], None]:
    """The engine's ``check_later``: the check runs as a task of the running loop, its
    verdict is handed to the engine, and the loop is woken to send the answer."""
    tasks: set[asyncio.Task[None]] = set()

    async def check(sha: str, text: str) -> None:
        verdict: TaskScript | ScriptRefused
        try:
            verdict = await check_isolated_async(text, f"deploy:{sha[:12]}")
        except ScriptRefused as exc:
            verdict = exc
        if not isinstance(verdict, ScriptRefused):
            # Its plugins (and the slot assignment's solver) are loaded now, in a thread,
            # not in the loop when its actors start or its groups are released.
            loaded = await asyncio.to_thread(prefetch, verdict)
            _log("prefetched", script=sha[:12], loaded=loaded)
        engine.checked(sha, verdict, clock())
        inbox.poke()

    def start(sha: str, text: str) -> None:
        task = asyncio.get_running_loop().create_task(check(sha, text))
        tasks.add(task)  # kept until done: the loop holds tasks only weakly
        task.add_done_callback(tasks.discard)

    return start


def _operator_override(autopilot: MavlinkVehicle | Ros2Vehicle, commands: list[Any]) -> None:
    """The operator's ``vehicle_land`` / ``vehicle_hold`` / ``vehicle_resume`` events
    (``gs event``), carried out on the autopilot whatever the plugins ask."""
    from actorswarm.vehicles.mavlink.vehicle import OPERATOR_EVENTS

    for c in commands:
        if c.command == "Inject" and c.event in OPERATOR_EVENTS:
            autopilot.override(OPERATOR_EVENTS[c.event])
            _log("vehicle-override", name=c.event)


def run_daemon(options: DaemonOptions) -> int:
    """Run the daemon until a signal; returns the exit status."""
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    return asyncio.run(_main(options))
