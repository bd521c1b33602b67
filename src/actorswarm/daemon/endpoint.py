"""A platform's protocol endpoint: core node, task engine and actor runtime as one object.

The simulator hosts these three pieces itself (:class:`~actorswarm.sim.tasksim.TaskSim` on
:class:`~actorswarm.sim.swarm.SimSwarm`); a daemon hosts them through
:class:`PlatformEndpoint`, which does what the simulator's host does between them. No clock,
no socket: the caller gives ``now`` and moves the bytes (:func:`actorswarm.daemon.serve`).

One way in, one way out
-----------------------
Packets come in only through the host's :class:`~actorswarm.security.pipeline.Pipeline`
(the guard checks the bytes, :meth:`PlatformEndpoint.receive_packet` gets the packet), and
leave only through :meth:`PlatformEndpoint.ready`. The endpoint holds no packets of its
own: :meth:`~PlatformEndpoint.ready` takes the node's output with one
:meth:`~actorswarm.core.node.Node.ready` per round, hands the events to the engine, and goes
on until the node has nothing more to say (``has_ready``: the engine's reaction may make
the node send or report more); it returns the packets of every round, in the order they
were taken.

The engine reacts when ``ready()`` is taken, so a host takes it after every packet it hands
over and after every :meth:`~PlatformEndpoint.tick` (the daemon's loop:
:meth:`Pipeline.receive_all <actorswarm.security.pipeline.Pipeline.receive_all>` with
``flush_each``, then a flush after the tick) — what the simulator's host does with a node.
The engine then reacts to each packet's events before the next packet of a batch reaches
the node, and the packets leave in the order they were made, each packet's answer as soon
as it is made. A host that never takes ``ready()`` leaves the engine deaf to the node.

Why so: an endpoint that serviced its node itself after each packet would have to keep the
packets somewhere until the loop sent them after the batch — a second holder on the way
out. Of the ways to keep none, taking ``ready()`` once per batch would let the engine react
only after the whole batch (a different daemon: a packet later in the batch would find the
node in another state); handing the endpoint the pipeline's ``send`` when it is made would
be a second way out, and a daemon opens its transport only after its endpoint exists (it
may check a kept script first). Taking ``ready()`` per packet keeps what the daemon does —
the engine's reactions interleaved per packet, the order of the packets on the wire — with
one way out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

from actorswarm.core.config import CoreConfig
from actorswarm.core.node import Node, Outgoing, Ready
from actorswarm.core.wire import Packet
from actorswarm.dsl.model import TaskScript
from actorswarm.engine.engine import TaskEngine
from actorswarm.engine.plan import Plan
from actorswarm.runtime.actor_runtime import ActorRuntime
from actorswarm.runtime.collective import NodeCollective
from actorswarm.runtime.context import Camera, Vehicle
from actorswarm.runtime.storage import BackupStore

__all__ = ["Endpoint", "PlatformEndpoint"]

#: A node that keeps producing output for this many rounds in one call is stopped there
#: (the rest goes out on the next call): a guard against a feedback loop, never hit in tests.
_MAX_ROUNDS = 1000

#: How often a daemon steps each running actor (Hz): the runtime's default, the paper's.
STEP_RATE = 10.0


class Endpoint(Protocol):
    """What a host loop drives: a platform (:class:`PlatformEndpoint`) or the ground
    station (:class:`~actorswarm.ground.station.GroundStation`). Packets come in checked
    (``receive_packet``, from the loop's pipeline) and go out through ``ready()``."""

    def receive_packet(self, packet: Packet, now: float) -> None: ...

    def tick(self, now: float) -> None: ...

    def next_deadline(self) -> float | None: ...

    def ready(self) -> Ready: ...


class PlatformEndpoint:
    """Platform ``platform`` of swarm ``swarm`` in its ``incarnation``; the task engine
    starts without a script (the ground station deploys one) and backs up to ``store``.

    Actors step at :data:`STEP_RATE`; ``step_slack`` (see
    :class:`~actorswarm.runtime.actor_runtime.ActorRuntime`) defaults to the core's
    ``heartbeat_slack`` (at most half a step period), so that a daemon's actor steps ride
    on the wakes its heartbeats ride on."""

    def __init__(
        self,
        platform: int,
        *,
        swarm: str,
        incarnation: int,
        now: float,
        config: CoreConfig | None = None,
        store: BackupStore | None = None,
        vehicle: Vehicle | None = None,
        camera: Camera | None = None,
        areas: Mapping[str, Sequence[tuple[float, float]]] | None = None,
        seed: int = 0,
        step_slack: float | None = None,
    ) -> None:
        config = config or CoreConfig()
        self.node = Node(platform, swarm=swarm, incarnation=incarnation, config=config, now=now)
        if step_slack is None:
            # The steps ride on the wakes the heartbeats ride on (at most half a period).
            step_slack = min(config.heartbeat_slack or 0.0, 0.5 / STEP_RATE)
        self.runtime = ActorRuntime(
            platform,
            seed=seed,
            vehicle=vehicle,
            camera=camera,
            areas=areas,
            rate=STEP_RATE,
            step_slack=step_slack,
        )
        self.runtime.collective = NodeCollective(self.node, lambda: self.runtime.now)
        empty = Plan.build(TaskScript(name="(none deployed)", version="0", actors=()))
        self.engine = TaskEngine(self.node, empty, self.runtime, store=store)
        # The time of the last host call: the engine reads the node's events at that time.
        self._now = now

    def __repr__(self) -> str:
        n = self.node
        return (
            f"PlatformEndpoint(platform={n.platform}, incarnation={n.incarnation}, "
            f"master={n.master}, running={list(self.runtime.running())})"
        )

    # --- the host interface -------------------------------------------------------------

    def receive_packet(self, packet: Packet, now: float) -> None:
        """A packet checked and decoded by the host's pipeline (its guard): the one way in.
        The engine reacts to what it caused at the next :meth:`ready`."""
        self._now = now
        self.node.receive_packet(packet, now)

    def tick(self, now: float) -> None:
        """Run whatever is due at ``now``: the node's timers and the engine's steps (the
        engine reacts to the node's events at the next :meth:`ready`)."""
        self._now = now
        if self.node.due(now):
            self.node.tick(now)
        deadline = self.engine.next_deadline()
        # Within the runtime's step slack the engine ticks too: an actor step then rides
        # on this wake (the engine's other timers check their own times).
        if deadline is not None and deadline <= now + self.runtime.step_window:
            self.engine.tick(now)

    def next_deadline(self) -> float | None:
        """The earliest time :meth:`tick` is due."""
        times = [
            t for t in (self.node.next_deadline(), self.engine.next_deadline()) if t is not None
        ]
        return min(times) if times else None

    def ready(self) -> Ready:
        """The packets to send since the last call (the one way out), in the order they were
        taken from the node, round by round: each round's events go to the engine, at the
        time of the last :meth:`receive_packet` or :meth:`tick`, before the next round is
        taken. No events: the engine read them. Take it after every packet handed over and
        every tick (see the module's documentation)."""
        node = self.node
        now = self._now
        packets: list[Outgoing] = []
        for _ in range(_MAX_ROUNDS):
            ready = node.ready()
            packets += ready.packets
            for event in ready.events:
                self.engine.on_core_event(event, now)
            if not node.has_ready:
                break
        return Ready(packets)

    def backup(self, *, changed_only: bool = False) -> int | None:
        """Save the actors and their plugins' state to the backup store now (what the
        operator's ``gs backup`` does); returns the backup's generation, or None when no
        script runs (there is nothing to resume). ``changed_only``: nothing is written (and
        None returned) when the newest backup already holds this very state."""
        if not self.engine.script_sha:
            return None
        snapshot = self.runtime.snapshot()
        if changed_only and self.engine.store.latest() == snapshot:
            return None
        return self.engine.store.write(snapshot)
