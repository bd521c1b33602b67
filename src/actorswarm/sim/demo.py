"""The collective-core demo: a simulated swarm living through the faults it is built for.

Timeline (virtual time): the swarm boots and elects a master; every platform passes a
barrier every half second (the paper's gather/scatter: each learns its index); all claim a
``leader`` role with quota 1; the master crashes in the middle of the barrier rounds; it
reboots in a new incarnation (the sticky master stays); the swarm is cut in two (two masters,
each side keeps working) and healed (one master again, the lower ID). Every invariant is
checked throughout, and the run is replayable from its seed.
"""

from __future__ import annotations

import time
from typing import Any

from rich.console import Console
from rich.table import Table

from actorswarm.core.config import CoreConfig
from actorswarm.core.events import (
    BarrierFired,
    BecameMaster,
    HandshakeComplete,
    RoleGranted,
    RoleRevoked,
    SteppedDown,
)
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.swarm import SimSwarm
from actorswarm.sim.workload import BarrierRounds, RoleChurn

DURATION = 14.0


def run_demo(
    *, size: int, seed: int, loss: float, latency: float, console: Console
) -> dict[str, Any]:
    """Run the demo, print its story, return a JSON-ready report."""
    wall = time.perf_counter()
    link = LinkModel(loss=loss, latency=latency, jitter=latency / 2)
    swarm = SimSwarm(size, seed=seed, config=CoreConfig(), link=link)
    BarrierRounds(swarm, key=1, every=0.5, start=1.0).install()
    churn = RoleChurn(swarm, seed, role="leader", quota=1, every=0.2, start=1.5, release_p=0.0)
    churn.install()
    half = list(range(1, size // 2 + 1))
    story: list[tuple[float, str]] = []

    def note(text: str) -> None:
        story.append((swarm.now, text))

    def crash_master() -> None:
        masters = swarm.current_masters()
        if masters:
            note(f"[red]crash of master {masters[0]}[/] (mid-barrier)")
            swarm.crash(masters[0])

    def reboot() -> None:
        note("[yellow]platform 1 reboots[/] (new incarnation)")
        swarm.restart(1)

    def cut() -> None:
        note(f"[magenta]partition[/] {half} | the rest")
        swarm.partition([half])

    def heal() -> None:
        note("[green]heal[/]")
        swarm.heal()

    swarm.at(3.05, crash_master)
    swarm.at(5.0, reboot)
    swarm.at(7.0, cut)
    swarm.at(10.0, heal)

    fired: dict[int, int] = {}

    def listener(t: float, node: Any, event: Any) -> None:
        if isinstance(event, BecameMaster):
            story.append((t, f"platform {node.platform} claims master, epoch {event.epoch}"))
        elif isinstance(event, HandshakeComplete):
            story.append(
                (t, f"  master {node.platform}: handshake complete ({event.members} members)")
            )
        elif isinstance(event, SteppedDown):
            story.append((t, f"platform {node.platform} steps down for {event.to}"))
        elif isinstance(event, BarrierFired):
            fired[node.platform] = fired.get(node.platform, 0) + 1
            if (not event.completion and fired[node.platform] <= 2) or event.completion:
                kind = "completes" if event.completion else "releases"
                story.append(
                    (
                        t,
                        f"  master {node.platform} {kind} barrier 1/{event.generation}: "
                        f"{len(event.chosen)} platforms, indices 1..{len(event.chosen)}",
                    )
                )
        elif isinstance(event, RoleGranted):
            story.append((t, f"  platform {node.platform} is granted role {event.role!r}"))
        elif isinstance(event, RoleRevoked):
            story.append((t, f"  platform {node.platform} loses role {event.role!r} (quota)"))

    swarm.listeners.append(listener)
    with console.status("simulating") as status:
        t = 0.0
        while t < DURATION:
            t = min(DURATION, t + 0.5)
            swarm.run_until(t)
            status.update(f"simulated {t:.1f} s of {DURATION:.0f} s")
    violations = swarm.finish()
    nodes = swarm.nodes
    masters = swarm.current_masters()
    problems = []
    if len(masters) != 1:
        problems.append(f"expected one master at the end, found {masters}")
    releases = sum(1 for e in swarm.log if type(e.event).__name__ == "BarrierReleased")

    console.rule(f"actorswarm demo — {size} platforms, seed {seed}")
    console.print(
        f"radio: {loss:.0%} loss, {latency * 1000:.0f} ms latency (+ up to "
        f"{latency * 500:.0f} ms jitter); heartbeat 100 ms, T_leave 500 ms"
    )
    for when, text in sorted(story, key=lambda x: x[0]):
        console.print(f"{when:7.3f} s  {text}")
    table = Table("platform", "incarnation", "master", "epoch", "view", "roles", "sent", "recv")
    traffic = swarm.radio.traffic
    for p in sorted(nodes):
        n = nodes[p]
        sent, _, recv, _ = traffic.totals(p)
        table.add_row(
            str(p),
            str(n.incarnation),
            "★" if n.is_master else str(n.master),
            str(n.epoch),
            str(len(n.view)),
            ",".join(sorted(n.roles.held)) or "-",
            str(sent),
            str(recv),
        )
    console.print(table)
    console.print(f"{releases} barrier passes in {swarm.now:.0f} s of virtual time")
    if violations or problems:
        for v in [*violations, *problems]:
            console.print(f"[red]✗ {v}[/]")
        console.print(f"replay: actorswarm swarm demo --seed {seed} --size {size} --loss {loss}")
    else:
        console.print(
            "[green]✓ every invariant held[/]: one master per component, all-or-nothing "
            "releases, role quotas, exactly-once delivery, monotonic epochs"
        )
    console.print(f"(wall clock {time.perf_counter() - wall:.1f} s)")
    return {
        "seed": seed,
        "size": size,
        "sim_time_s": swarm.now,
        "masters": [
            {"t": m.t, "platform": m.platform, "epoch": m.epoch, "handshake_done": m.handshake_done}
            for m in swarm.masters
        ],
        "final": {
            str(p): {"master": n.master, "epoch": n.epoch, "roles": sorted(n.roles.held)}
            for p, n in nodes.items()
        },
        "barrier_passes": releases,
        "traffic": traffic.snapshot(),
        "violations": violations,
        "problems": problems,
    }
