"""``actorswarm sim``: a task script run by task engines on a simulated swarm (no world yet).

Every platform the script starts gets a core :class:`~actorswarm.core.Node` (inside
:class:`~actorswarm.sim.swarm.SimSwarm`), a :class:`~actorswarm.engine.TaskEngine` and the
actor runtime (plugins from the registry, no vehicle); the task starts at time 0.
Ground-station events, crashes, restarts, partitions and heals happen at the virtual times
given. The report has the keys of
docs/design.md §7: ``completed``, ``sim_time_s``, ``final_actors``, ``transitions`` (with their
``cause``), ``masters``, ``traffic`` and ``violations``, and ``channel``: the load on the
radio's channel (:meth:`~actorswarm.sim.radio.ChannelStats.as_dict`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import CoreEvent
from actorswarm.core.node import Node
from actorswarm.core.wire import Packet
from actorswarm.dsl.model import TaskScript
from actorswarm.dsl.syntax import id_ranges
from actorswarm.engine.engine import TaskEngine
from actorswarm.engine.plan import Plan
from actorswarm.engine.records import FiredRecord
from actorswarm.ground.station import GroundStation
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.runtime.collective import NodeCollective
from actorswarm.runtime.storage import MemoryBackupStore
from actorswarm.security.pipeline import Pipeline
from actorswarm.sim.hops import HopWatch, hops_line
from actorswarm.sim.port import RadioPort
from actorswarm.sim.radio import Airtime, LinkModel, Transmission
from actorswarm.sim.scheduler import Timer
from actorswarm.sim.swarm import SimSwarm
from actorswarm.sim.vehicle_faults import VEHICLE_FAULT_EVENT, FaultyVehicle, VehicleFault
from actorswarm.world.config import WorldConfig
from actorswarm.world.separation import (
    SeparationBreachError,
    SeparationMonitor,
    separation_line,
)
from actorswarm.world.vehicles import FLYING, LANDING, TAKEOFF
from actorswarm.world.world import World


@dataclass(frozen=True, slots=True)
class GroundEvent:
    """``--event NAME@T[:IDS]``: the ground station sends ``name`` at ``t`` (to ``ids``,
    or to every platform)."""

    name: str
    t: float
    ids: frozenset[int] | None = None


@dataclass(frozen=True, slots=True)
class Fault:
    """``--kill ID@T``, ``--restart ID@T``, ``--partition IDS@T``, ``--heal @T``.

    ``master``: a kill of whichever platform is master at ``t`` (``--kill master@T``: every
    master, while a partition has several; nobody when there is none), or the restart of the
    platforms the latest such kill took (``--restart master@T``); ``ids`` is then empty.
    """

    kind: str
    t: float
    ids: frozenset[int] = frozenset()
    master: bool = False

    def option(self) -> list[str]:
        """The ``actorswarm sim`` options that give this fault."""
        from actorswarm.dsl.syntax import id_ranges

        ids = "master" if self.master else id_ranges(self.ids)
        if self.kind == "heal":
            return ["--heal", f"@{self.t:.12g}"]
        return [f"--{self.kind}", f"{ids}@{self.t:.12g}"]


@dataclass(slots=True)
class _Host:
    engine: TaskEngine
    timer: Timer | None = None
    timer_at: float = float("inf")
    #: The newest of the engine's transitions when its actors were last backed up.
    backed_up: object = None


@dataclass(slots=True)
class TaskSim:
    """One simulated run of ``script``."""

    script: TaskScript
    seed: int = 0
    link: LinkModel = field(default_factory=LinkModel)
    config: CoreConfig = field(default_factory=CoreConfig)
    #: Start the task at time 0 (the script counts as deployed); False: the ground station
    #: (:attr:`ground`) deploys and starts it.
    auto_start: bool = True
    #: The simulated world (vehicles, targets, position-driven radio); None: no vehicles.
    world_config: WorldConfig | None = None
    #: The radio's shared channel (:attr:`~actorswarm.sim.radio.SimRadio.airtime`); None:
    #: no airtime modelled, packets never wait for the channel.
    airtime: Airtime | None = None
    #: Every pair of airborne vehicles must keep at least this many metres (over the
    #: world's per-kind separation), and a breach stops the run (``--min-separation``).
    #: None: the world's separations, fatal only with its ``[safety] fatal_separation``.
    min_separation: float | None = None
    #: Autopilots that are ready late, refuse to take off or drain their battery faster
    #: (:mod:`actorswarm.sim.vehicle_faults`); ignored without a world.
    vehicle_faults: tuple[VehicleFault, ...] = ()
    world: World | None = field(default=None, init=False)
    #: How close the airborne vehicles come (:mod:`actorswarm.world.separation`), measured
    #: after every physics step; None without a world.
    separation: SeparationMonitor | None = field(default=None, init=False)
    #: How many radio hops the swarm spans over the run; None without a world.
    hops: HopWatch | None = field(default=None, init=False)
    #: Why the run stopped before its end (a fatal separation breach); None: it did not.
    halted: str | None = field(default=None, init=False)
    ground: GroundStation | None = field(default=None, init=False)
    _gs_timer: Timer | None = field(default=None, init=False)
    _gs_at: float = field(default=float("inf"), init=False)
    _gs_pipeline: Pipeline | None = field(default=None, init=False)
    swarm: SimSwarm = field(init=False)
    plan: Plan = field(init=False)
    hosts: dict[int, _Host] = field(default_factory=dict, init=False)
    records: list[dict[str, Any]] = field(default_factory=list, init=False)
    ignored: list[dict[str, Any]] = field(default_factory=list, init=False)
    #: Every transition group the masters released, and to whom (the benchmarks tell a
    #: platform left out of a release from one that is merely slow).
    fired: list[FiredRecord] = field(default_factory=list, init=False)
    _sent: int = field(default=0, init=False)
    plugin_failures: list[dict[str, Any]] = field(default_factory=list, init=False)
    #: Platforms lost with their vehicle (battery empty, fallen): ``{"t", "platform"}``.
    wrecks: list[dict[str, Any]] = field(default_factory=list, init=False)
    #: Each platform's backup storage (its "disk": it outlives a crash).
    stores: dict[int, MemoryBackupStore] = field(default_factory=dict, init=False)
    #: When each platform's task began (its engine's ``began``), kept on its "disk" as a
    #: daemon keeps it in its state directory: a restarted platform goes on in that task.
    began: dict[int, float] = field(default_factory=dict, init=False)
    #: The platforms the latest ``--kill master`` crashed (``--restart master`` boots them).
    _master_kills: tuple[int, ...] = field(default=(), init=False)
    _faults_raised: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        self.plan = Plan.build(self.script)
        platforms = sorted(self.script.platform_ids())
        if not platforms:
            raise ValueError("the script starts no platform")
        self.swarm = SimSwarm(platforms, seed=self.seed, config=self.config, link=self.link)
        self.swarm.listeners.append(self._on_core_event)
        self.swarm.radio.airtime = self.airtime
        if self.world_config is not None:
            self.world = World(self.world_config, platforms)
            self.separation = self._monitor(self.world_config, self.world)
            self.hops = HopWatch(self.world_config.radio.relay)
            for vf in self.vehicle_faults:
                if vf.kind == "drain":
                    for p in sorted(vf.ids):
                        self.world.fleet.drain_faster(p, vf.value)
            self.swarm.radio.link_fn = self._link
            if self.world_config.radio.relay:
                self.swarm.radio.relay_fn = self._relays
            self.swarm.at(0.0, self._physics)
        self.ground = GroundStation(swarm=self.swarm.swarm, config=self.config)
        guard = self.swarm.keys.guard("ground", max_bytes=self.config.max_packet_bytes)
        self._gs_pipeline = Pipeline(self.ground, RadioPort(self.swarm.radio, 0), guard)
        self.swarm.radio.attach(0, self._gs_deliver)
        for p in platforms:
            self._boot(p)

    def _boot(self, platform: int, *, restarted: bool = False) -> None:
        world = self.world
        runtime = ActorRuntime(
            platform,
            seed=self.seed,
            vehicle=None if world is None else self._vehicle(platform),
            camera=None if world is None else world.camera(platform),
            areas=None if world is None else world.area_polygons(),
        )
        runtime.collective = NodeCollective(self.swarm.node(platform), lambda: runtime.now)
        store = self.stores.setdefault(platform, MemoryBackupStore())  # survives crashes
        engine = TaskEngine(self.swarm.node(platform), self.plan, runtime, store=store)
        self.hosts[platform] = _Host(engine)
        now = self.swarm.now
        # The task started at time 0 when it starts itself (a platform added later joins
        # that task); a platform restarted goes on in the task it ran.
        began = self.began.get(platform, 0.0 if self.auto_start else None)
        if restarted and store.latest() is not None:
            # Resume from the latest backup; a backup that cannot be restored falls back to
            # the task's initial actors.
            self.swarm.call(platform, lambda n: self._resume_or_start(engine, now, began))
        elif self.auto_start:
            self.swarm.call(platform, lambda n: engine.start(now, began=began))
        self._arm(platform)

    def _vehicle(self, platform: int) -> Any:
        """The world's vehicle of ``platform``, behind its autopilot's faults if it has any."""
        assert self.world is not None
        vehicle = self.world.vehicle(platform)
        late = [f.value for f in self.vehicle_faults if f.kind == "late" and platform in f.ids]
        refuses = any(f.kind == "refuse" and platform in f.ids for f in self.vehicle_faults)
        if not late and not refuses:
            return vehicle
        return FaultyVehicle(
            vehicle,
            clock=lambda: self.swarm.now,
            schedule=self.swarm.at,
            fault=lambda reason: self._vehicle_fault(platform, reason),
            ready_at=max(late, default=0.0),
            refuses=refuses,
        )

    def _vehicle_fault(self, platform: int, reason: str) -> None:
        """The autopilot of ``platform`` failed a command for good: the task event the
        daemon raises (:data:`VEHICLE_FAULT_EVENT`), local to that platform."""
        host = self.hosts.get(platform)
        if host is None:
            return
        self._faults_raised += 1
        occasion = f"vehicle.{platform}:{self._faults_raised}"
        engine = host.engine
        self.swarm.call(
            platform,
            lambda n: engine.inject(
                VEHICLE_FAULT_EVENT, self.swarm.now, data={"reason": reason}, occasion=occasion
            ),
        )
        self._arm(platform)

    def _link(self, src: int, dst: int) -> tuple[float, float]:
        """The world's radio model between two vehicles (the ground station, platform 0, is
        taken to be in range of everyone)."""
        assert self.world is not None
        if src == 0 or dst == 0:
            return 0.0, 0.0
        return self.world.link(src, dst)

    def _relays(self, src: int, dst: int | None) -> int:
        """How many times the world's relays send on a packet from ``src`` to ``dst``
        (None: a broadcast). The ground station's packets are taken to reach everyone
        directly, as its links are (:meth:`_link`)."""
        assert self.world is not None
        if src == 0 or dst == 0:
            return 0
        return self.world.relays(src, dst)

    def _physics(self) -> None:
        """Advance the world in its fixed steps, in step with virtual time. A platform whose
        vehicle died and hit the ground is gone: its node crashes (the robot, its computer
        and its radio are one), so the swarm notices it as it would a real loss."""
        assert self.world is not None and self.world_config is not None
        self.world.step_to(self.swarm.now)
        if self.hops is not None:
            self.hops.observe(self.world)
        for platform in self.world.wrecked():
            if platform in self.hosts:
                self.wrecks.append({"t": round(self.swarm.now, 6), "platform": platform})
                self.swarm.crash(platform)
                self._retire(platform)
        self.swarm.scheduler.after(self.world_config.world.step, self._physics)
        # Last: with a fatal separation this raises, out of the scheduler (_run_to).
        self._separate()

    def _monitor(self, config: WorldConfig, world: World) -> SeparationMonitor:
        minimums = config.separations()
        fatal = config.safety.fatal_separation
        if self.min_separation is not None:
            if not self.min_separation > 0:
                raise ValueError(
                    f"--min-separation must be a number of metres > 0, not {self.min_separation}"
                )
            minimums = {k: max(v, self.min_separation) for k, v in minimums.items()}
            fatal = True
        return SeparationMonitor(
            world.platforms,
            [minimums[kind] for kind in world.fleet.kinds],
            fatal=fatal,
            minimums=minimums,
        )

    def _separate(self) -> None:
        """Measure the separation of the vehicles in the air now."""
        assert self.world is not None and self.separation is not None
        fleet = self.world.fleet
        modes = fleet.modes
        airborne = (modes == TAKEOFF) | (modes == FLYING) | (modes == LANDING)
        self.separation.observe(self.world.time, fleet.positions, airborne)

    @staticmethod
    def _resume_or_start(engine: TaskEngine, now: float, began: float | None) -> None:
        if not engine.resume(now, began=began):
            engine.start(now, began=began)

    def _retire(self, platform: int) -> None:
        """The platform is gone (crashed, rebooting, wrecked): what it ran ends now, as a
        transition to nothing with cause ``lost``, so timelines do not show it running on."""
        host = self.hosts.pop(platform, None)
        if host is None:
            return
        if host.timer is not None:
            host.timer.cancel()
        if host.engine.began is not None:
            self.began[platform] = host.engine.began
        self._collect(host.engine)
        for actor in host.engine.runtime.running():
            self.records.append(
                {
                    "t": round(self.swarm.now, 6),
                    "platform": platform,
                    "from": actor,
                    "to": "",
                    "event": "",
                    "cause": "lost",
                }
            )

    def _collect(self, engine: TaskEngine) -> None:
        for rec in engine.transitions:
            self.records.append(
                {
                    "t": round(rec.t, 6),
                    "platform": rec.platform,
                    "from": rec.src,
                    "to": rec.dst,
                    "event": rec.event,
                    "cause": rec.cause,
                }
            )
        engine.transitions.clear()
        for t, event, why in engine.ignored:
            self.ignored.append(
                {"t": round(t, 6), "platform": engine.node.platform, "event": event, "why": why}
            )
        engine.ignored.clear()
        # Commands are the daemon's to report; here they would only pile up.
        engine.commands.clear()
        self.fired += engine.fired
        engine.fired.clear()
        failures = getattr(engine.runtime, "failures", [])
        for f in failures:
            self.plugin_failures.append(
                {
                    "t": round(f.t, 6),
                    "platform": engine.node.platform,
                    "actor": f.actor,
                    "plugin": f.plugin,
                    "error": f.message,
                }
            )
        failures.clear()

    # --- driving --------------------------------------------------------------------------

    def _on_core_event(self, t: float, node: Node, event: CoreEvent) -> None:
        host = self.hosts.get(node.platform)
        if host is None or host.engine.node is not node:
            return
        host.engine.on_core_event(event, t)
        self._arm(node.platform)

    def _arm(self, platform: int) -> None:
        """After the engine of ``platform`` acted: back its actors up if they switched, and
        wake it when it is next due."""
        host = self.hosts.get(platform)
        if host is None:
            return
        transitions = host.engine.transitions
        if transitions and transitions[-1] is not host.backed_up:
            # As a daemon does after every switch: a crash from now on resumes these actors
            # (a restarted platform rejoins the task where it was, not at its start).
            host.backed_up = transitions[-1]
            host.engine.store.write(host.engine.runtime.snapshot())
        deadline = host.engine.next_deadline()
        if deadline is None or deadline >= host.timer_at:
            return
        if host.timer is not None:
            host.timer.cancel()
        host.timer_at = max(deadline, self.swarm.now)
        host.timer = self.swarm.at(host.timer_at, self._tick, platform)

    def _tick(self, platform: int) -> None:
        host = self.hosts.get(platform)
        if host is None:
            return
        host.timer = None
        host.timer_at = float("inf")
        self.swarm.call(platform, lambda n: host.engine.tick(self.swarm.now))
        self._arm(platform)

    # --- the ground station (platform 0) ----------------------------------------------------

    def operate(self, action: Callable[[GroundStation, float], object]) -> object:
        """Run ``action(ground_station, now)`` now (deploy, start, a command) and send."""
        assert self.ground is not None
        result = action(self.ground, self.swarm.now)
        self._gs_service()
        return result

    def _gs_deliver(self, tx: Transmission[Packet], now: float) -> None:
        assert self.ground is not None and self._gs_pipeline is not None
        self._gs_pipeline.receive(tx.data, now)
        if self.ground.has_output:
            self._gs_service()

    def _gs_service(self) -> None:
        assert self.ground is not None and self._gs_pipeline is not None
        self._gs_pipeline.flush()
        deadline = self.ground.next_deadline()
        if deadline is not None and deadline < self._gs_at:
            if self._gs_timer is not None:
                self._gs_timer.cancel()
            self._gs_at = max(deadline, self.swarm.now)
            self._gs_timer = self.swarm.at(self._gs_at, self._gs_tick)

    def _gs_tick(self) -> None:
        assert self.ground is not None
        self._gs_timer = None
        self._gs_at = float("inf")
        self.ground.tick(self.swarm.now)
        self._gs_service()

    def ground_event(self, event: GroundEvent) -> None:
        """The ground station's event reaches every (or every listed) live platform."""
        self._sent += 1
        occasion = f"gs:{self._sent}"
        for p in sorted(self.hosts):
            if event.ids is None or p in event.ids:
                self._inject(p, event.name, occasion, shared=event.ids is None)

    def _inject(self, platform: int, event: str, occasion: str, *, shared: bool) -> None:
        engine = self.hosts[platform].engine
        self.swarm.call(
            platform,
            lambda n: engine.inject(event, self.swarm.now, occasion=occasion, shared=shared),
        )
        self._arm(platform)

    def fault(self, fault: Fault) -> None:
        if fault.kind == "kill":
            ids = sorted(fault.ids)
            if fault.master:
                ids = [p for p in self.swarm.current_masters() if p in self.hosts]
                self._master_kills = tuple(ids)
            for p in ids:
                self.swarm.crash(p)
                self._retire(p)
        elif fault.kind == "restart":
            for p in self._master_kills if fault.master else sorted(fault.ids):
                self._retire(p)
                self.swarm.restart(p)
                self._boot(p, restarted=True)
        elif fault.kind == "partition":
            self.swarm.partition([sorted(fault.ids)])
        elif fault.kind == "heal":
            self.swarm.heal()
        else:
            raise ValueError(f"unknown fault {fault.kind!r}")

    def schedule(self, events: Iterable[GroundEvent] = (), faults: Iterable[Fault] = ()) -> None:
        """Have the ground-station ``events`` and the ``faults`` happen at their times."""
        for ev in events:
            self.swarm.at(ev.t, self.ground_event, ev)
        for f in faults:
            self.swarm.at(f.t, self.fault, f)

    def advance(self, until: float) -> list[dict[str, Any]]:
        """Run to ``until`` seconds of virtual time and return the transitions made since
        the last call (the report's ``transitions`` entries), oldest first: a caller that
        advances in slices sees the mission unfold."""
        before = len(self.records)
        self._run_to(until)
        for host in self.hosts.values():
            self._collect(host.engine)
        return sorted(self.records[before:], key=lambda r: (r["t"], r["platform"]))

    def run(
        self,
        duration: float,
        *,
        events: Iterable[GroundEvent] = (),
        faults: Iterable[Fault] = (),
    ) -> dict[str, Any]:
        """Run for ``duration`` seconds of virtual time; return the JSON-ready report."""
        self.schedule(events, faults)
        self._run_to(duration)
        return self.report()

    def _run_to(self, until: float) -> None:
        """Run to ``until``, unless a fatal separation breach stops the run (for good)."""
        if self.halted is not None:
            return
        try:
            self.swarm.run_until(until)
        except SeparationBreachError as exc:
            self.halted = str(exc)

    def report(self) -> dict[str, Any]:
        for host in self.hosts.values():
            self._collect(host.engine)
        final = {
            str(p): list(host.engine.runtime.running()) for p, host in sorted(self.hosts.items())
        }
        terminal = {a.name for a in self.script.actors} - {
            t.actor for ts in self.script.transitions.values() for t in ts
        }
        completed = (
            self.halted is None
            and bool(final)
            and all(actors and all(a in terminal for a in actors) for actors in final.values())
        )
        # Why not: the actors still held that have transitions, with the events they wait
        # for (a platform running nothing waits for nothing it can get).
        waiting = {
            actor: sorted({t.event for ts in self.script.transitions.values() for t in ts
                           if t.actor == actor})
            for actors in final.values()
            for actor in actors
            if actor not in terminal
        }  # fmt: skip
        traffic = {
            str(p): {k: v for k, v in row.items() if k != "by_kind"}
            for p, row in self.swarm.traffic().items()
        }
        separation = None if self.separation is None else self.separation.result()
        separation_lines = [] if separation is None else separation.violations()
        return {
            "completed": completed,
            "waiting": dict(sorted(waiting.items())),
            "sim_time_s": round(self.swarm.now, 6),
            "final_actors": final,
            "transitions": sorted(self.records, key=lambda r: (r["t"], r["platform"])),
            "masters": [
                {"t": round(m.t, 6), "platform": m.platform, "epoch": m.epoch}
                for m in self.swarm.masters
            ],
            "traffic": traffic,
            "ignored_events": self.ignored,
            "plugin_failures": self.plugin_failures,
            "wrecks": list(self.wrecks),
            "violations": self.swarm.finish() + separation_lines,
            "separation": None if separation is None else separation.as_dict(),
            "radio": None if self.hops is None else self.hops.as_dict(),
            "halted": self.halted,
            "seed": self.seed,
            "channel": self.swarm.radio.channel_stats().as_dict(),
        }


def _time(text: str, flag: str) -> float:
    try:
        t = float(text)
    except ValueError:
        raise ValueError(f"{flag}: {text!r} is not a time in seconds") from None
    if not 0 <= t < 1e9:
        raise ValueError(f"{flag}: the time must be >= 0 seconds, got {text!r}")
    return t


def _ids(text: str, flag: str) -> frozenset[int]:
    from actorswarm.dsl.syntax import platform_ids

    try:
        return platform_ids(text)
    except ValueError as exc:
        raise ValueError(f"{flag}: {exc}") from None


def parse_event(text: str) -> GroundEvent:
    """``NAME@T[:IDS]`` (``--event``)."""
    name, sep, rest = text.partition("@")
    if not sep or not name.strip():
        raise ValueError(f"--event: expected NAME@T[:IDS] such as go_home_event@30, got {text!r}")
    when, colon, ids = rest.partition(":")
    return GroundEvent(
        name.strip(), _time(when, "--event"), _ids(ids, "--event") if colon else None
    )


def parse_fault(kind: str, text: str) -> Fault:
    """``--kill ID@T``, ``--restart ID@T``, ``--partition IDS[@T]``, ``--heal @T``; a kill or
    restart of ``master@T`` is of the master at ``T`` (:class:`Fault`)."""
    flag = f"--{kind}"
    ids, sep, when = text.partition("@")
    if kind in ("kill", "restart") and ids.strip() == "master":
        if not sep:
            raise ValueError(f"{flag}: expected master@T such as master@30, got {text!r}")
        return Fault(kind, _time(when, flag), master=True)
    if kind == "heal":
        if ids.strip():
            raise ValueError(f"--heal: expected @T such as @12, got {text!r}")
        return Fault("heal", _time(when, flag))
    if kind == "partition":
        return Fault("partition", _time(when, flag) if sep else 0.0, _ids(ids, flag))
    if not sep:
        raise ValueError(f"{flag}: expected ID@T such as 1@8, got {text!r}")
    return Fault(kind, _time(when, flag), _ids(ids, flag))


Step = tuple[float, float, str, str, str, str, list[int]]

#: At most this many plugin failures are printed one per line; the rest are counted.
FAILURES_SHOWN = 10


def failure_lines(failures: list[dict[str, Any]]) -> list[str]:
    """The report's ``plugin_failures`` for people: a count, then one line each (the first
    :data:`FAILURES_SHOWN`)."""
    if not failures:
        return []
    lines = [f"PLUGIN FAILURES: {len(failures)}"]
    for f in failures[:FAILURES_SHOWN]:
        lines.append(
            f"  {f['t']:7.2f} s  platform {f['platform']}, actor {f['actor']}, plugin "
            f"{f['plugin']}: {f['error']}"
        )
    if len(failures) > FAILURES_SHOWN:
        lines.append(f"  ... and {len(failures) - FAILURES_SHOWN} more (all in --json)")
    return lines


def steps(transitions: Iterable[dict[str, Any]]) -> list[Step]:
    """Transitions (report entries, time order) grouped into the steps of the task:
    ``(first t, last t, event, from, to, cause, platforms)`` for each same move on the same
    event within a second (one release may reach some platforms a retransmission later
    than others). Starts are left out."""
    out: list[Step] = []
    for t in transitions:
        if t["cause"] == "start":
            continue
        for i, (first, _, event, src, dst, cause, who) in enumerate(out):
            same = (event, src, dst, cause) == (t["event"], t["from"], t["to"], t["cause"])
            if same and t["t"] - first <= 1.0:
                out[i] = (first, t["t"], event, src, dst, cause, [*who, t["platform"]])
                break
        else:
            out.append(
                (t["t"], t["t"], t["event"], t["from"], t["to"], t["cause"], [t["platform"]])
            )
    return out


def why_not(report: dict[str, Any]) -> str:
    """Why a run did not complete, in a few words: which actors still have transitions and
    on how many platforms, and the events those wait for."""
    holders: dict[str, int] = {}
    idle = 0
    for actors in report["final_actors"].values():
        idle += not actors
        for actor in actors:
            holders[actor] = holders.get(actor, 0) + 1
    parts = []
    for actor, events in report.get("waiting", {}).items():
        on = f" waits for {' or '.join(events)}" if events else ""
        parts.append(f"{actor} on {holders.get(actor, 0)}{on}")
    if idle:
        parts.append(f"{idle} platform(s) run no actor")
    return "; ".join(parts) or "no platform ran"


def summary(report: dict[str, Any]) -> list[str]:
    """A few human-readable lines about a run's report."""
    lines = [
        f"simulated {report['sim_time_s']:.1f} s; completed: {report['completed']}"
        + ("" if report["completed"] else f" ({why_not(report)})"),
    ]
    for first, last, event, src, dst, cause, who in steps(report["transitions"]):
        spread = f" (+{(last - first) * 1000:.0f} ms)" if last > first else ""
        on = f" on {event}" if event else ""
        lines.append(
            f"  {first:7.2f} s{spread}  {len(who):3d} × {src or '-'} → {dst or '-'}"
            f" ({cause}{on}): {id_ranges(frozenset(who))}"
        )
    channel = report.get("channel")
    if channel is not None and channel["bitrate"] is not None:
        lines.append(
            f"channel: {channel['utilisation']:.0%} busy at {channel['bitrate']:,.0f} bit/s, "
            f"{channel['packets_per_s']:,.0f} packets/s, {channel['drops']} dropped, "
            f"longest wait {channel['max_queue_delay_s'] * 1000:.0f} ms"
            + (
                f"; {channel['relayed'] / channel['packets']:.0%} of the packets sent on by relays"
                if channel.get("relayed")
                else ""
            )
        )
    masters = ", ".join(f"{m['platform']}@{m['t']:.2f}s" for m in report["masters"])
    lines.append(f"masters: {masters or 'none'}")
    final: dict[str, list[str]] = {}
    for p, actors in report["final_actors"].items():
        final.setdefault(",".join(actors) or "-", []).append(p)
    lines.append("final: " + "; ".join(f"{a} on {len(ps)}" for a, ps in sorted(final.items())))
    if report["ignored_events"]:
        lines.append(f"ignored events: {len(report['ignored_events'])}")
    lines += failure_lines(report.get("plugin_failures", []))
    separation = report.get("separation")
    if separation is not None:
        lines.append(separation_line(separation))
    if report.get("radio") is not None:
        lines.append(hops_line(report["radio"]))
    if report.get("halted"):
        lines.append(f"HALTED: {report['halted']}")
    lines.append(
        "invariants: all held"
        if not report["violations"]
        else "VIOLATIONS:\n  " + "\n  ".join(report["violations"])
    )
    return lines
