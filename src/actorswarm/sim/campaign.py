"""Randomized, seeded fault campaigns: one seed -> one swarm, one fault schedule, one verdict.

Theory of operation
-------------------
:func:`make_case` turns a seed into a :class:`Case`: a swarm size, a detector and election
mode, a link model (loss, bursts, jitter, duplication, reordering) and a schedule of crashes,
restarts, partitions and heals. :func:`run_case` runs it with barrier rounds, role churn and
application messages on top, then a *quiet* period — partitions healed, crashed platforms
restarted, a clean radio — and checks

* every invariant of :mod:`actorswarm.sim.invariants` over the whole run, and
* that the swarm recovered: one master, followed by every live platform in one epoch, whose
  view holds every live platform, and barriers firing again.

Every case runs in one membership mode of the core (``CoreConfig.membership``: ``"star"``,
the default, or ``"broadcast"``); the mode does not change the schedule, so seed S names the
same faults in both modes. A failing case prints the command that replays it:
``actorswarm swarm campaign --seed S --membership M``. Many seeds at once, on every core:
:mod:`actorswarm.sim.campaign_runner`.

With ``renew`` (``--renew``) a case's barrier requests are all renewable, as the task
engine's are (:attr:`~actorswarm.core.wire.BarrierRequest.renew`), and a third barrier
round, of one platform at a time, makes the master renew requests often. The schedule is
the same; the run is another one (more requests, other packets), so a seed replays with
the ``renew`` it failed with.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any, Final

from actorswarm.core.config import CoreConfig, MembershipKind
from actorswarm.core.events import BarrierFired
from actorswarm.sim.radio import GilbertElliott, LinkModel
from actorswarm.sim.swarm import SimSwarm
from actorswarm.sim.workload import AppChatter, BarrierRounds, RoleChurn

#: The membership modes a case can run in, in the order a campaign of both runs them.
MEMBERSHIPS: Final[tuple[MembershipKind, ...]] = ("star", "broadcast")


def check_membership(membership: str) -> MembershipKind:
    """``membership`` as a mode of :data:`MEMBERSHIPS`; a :class:`ValueError` naming the
    choices otherwise."""
    for mode in MEMBERSHIPS:
        if membership == mode:
            return mode
    raise ValueError(f"membership: expected one of {', '.join(MEMBERSHIPS)}, got {membership!r}")


@dataclass(frozen=True, slots=True)
class Action:
    t: float
    kind: str  # crash | restart | partition | heal
    args: tuple[Any, ...] = ()

    def describe(self) -> str:
        return f"{self.kind}{list(self.args) if self.args else ''}@{self.t:.2f}"


@dataclass(frozen=True, slots=True)
class Case:
    seed: int
    size: int
    detector: str
    takeover: bool
    link: LinkModel
    actions: tuple[Action, ...]
    faults_until: float
    quiet: float
    membership: MembershipKind = "star"
    renew: bool = False

    def describe(self) -> str:
        """One line: the seed, the membership mode, the swarm, the link and the schedule."""
        link = self.link
        burst = "bursty " if link.burst is not None else ""
        return (
            f"seed {self.seed}: {self.membership} membership"
            f"{', renewable requests' if self.renew else ''}, {self.size} platforms, "
            f"{self.detector} detector"
            f"{', takeover' if self.takeover else ''}, {burst}loss {link.loss:.2f}, "
            f"jitter {link.jitter * 1000:.0f} ms, dup {link.duplicate:.2f}, "
            f"reorder {link.reorder:.2f}; " + ", ".join(a.describe() for a in self.actions)
        )

    @property
    def replay(self) -> str:
        """The command that runs this case again, event for event."""
        renew = " --renew" if self.renew else ""
        return f"actorswarm swarm campaign --seed {self.seed} --membership {self.membership}{renew}"


@dataclass(slots=True)
class CaseResult:
    case: Case
    violations: list[str]
    problems: list[str] = field(default_factory=list)
    fired_after_quiet: int = 0

    @property
    def ok(self) -> bool:
        return not self.violations and not self.problems

    def explain(self) -> str:
        lines = [f"FAILED {self.case.describe()}", f"  replay: {self.case.replay}"]
        lines += [f"  violation: {v}" for v in self.violations]
        lines += [f"  problem: {p}" for p in self.problems]
        return "\n".join(lines)


def make_case(seed: int, membership: MembershipKind = "star", *, renew: bool = False) -> Case:
    """The fault schedule of ``seed`` (deterministic), to run in ``membership`` mode, with
    renewable barrier requests when ``renew`` (the module docstring).

    The schedule depends on ``seed`` only: both modes of a seed get the same swarm, link and
    faults, and a seed keeps the schedule it has always had (the draws below must stay in
    this order). A ``membership`` outside :data:`MEMBERSHIPS` raises :class:`ValueError`.
    """
    membership = check_membership(membership)
    rng = random.Random(f"campaign:{seed}")
    size = rng.randint(3, 12)
    burst = None
    loss = rng.choice([0.0, 0.0, 0.05, 0.1, 0.2, 0.3])
    if rng.random() < 0.25:
        burst = GilbertElliott(
            p_good_to_bad=0.05, p_bad_to_good=0.3, loss_good=loss / 3, loss_bad=0.7
        )
        loss = 0.0
    link = LinkModel(
        loss=loss,
        latency=rng.choice([0.002, 0.01, 0.03]),
        jitter=rng.choice([0.0, 0.005, 0.02]),
        duplicate=rng.choice([0.0, 0.0, 0.05]),
        reorder=rng.choice([0.0, 0.0, 0.1]),
        burst=burst,
    )
    faults_until = 10.0
    actions: list[Action] = []
    down: set[int] = set()
    partitioned = False
    t = 1.5
    while True:
        t += rng.uniform(0.3, 2.0)
        if t >= faults_until:
            break
        roll = rng.random()
        ids = [p for p in range(1, size + 1) if p not in down]
        if roll < 0.35 and len(ids) > 1:
            # Crash the master (platform 1 often is) or anyone.
            victim = min(ids) if rng.random() < 0.5 else rng.choice(ids)
            down.add(victim)
            actions.append(Action(t, "crash", (victim,)))
        elif roll < 0.55 and down:
            back = rng.choice(sorted(down))
            down.discard(back)
            actions.append(Action(t, "restart", (back,)))
        elif roll < 0.8 and not partitioned and size >= 3:
            everyone = list(range(1, size + 1))
            rng.shuffle(everyone)
            cut = rng.randint(1, size - 1)
            actions.append(Action(t, "partition", (sorted(everyone[:cut]),)))
            partitioned = True
        elif partitioned:
            actions.append(Action(t, "heal"))
            partitioned = False
    return Case(
        seed=seed,
        size=size,
        detector=rng.choice(["timeout", "timeout", "phi"]),
        takeover=rng.random() < 0.2,
        link=link,
        actions=tuple(actions),
        faults_until=faults_until,
        quiet=6.0,
        membership=membership,
        renew=renew,
    )


def run_case(case: Case) -> CaseResult:
    """Run ``case`` in its membership mode; check the invariants and the recovery.

    Deterministic: the result depends on ``case`` only, never on the process it runs in.
    """
    config = CoreConfig(
        detector=case.detector,  # type: ignore[arg-type]
        takeover_on_join=case.takeover,
        membership=case.membership,
    )
    swarm = SimSwarm(case.size, seed=case.seed, config=config, link=case.link)
    end = case.faults_until + case.quiet
    renew = case.renew
    BarrierRounds(swarm, key=1, every=0.25, start=1.0, renew=renew).install()
    BarrierRounds(swarm, key=2, need=2, every=0.5, start=1.2, timeout=2.0, renew=renew).install()
    if renew:
        # One platform per firing, every platform asking: most requests cross a firing.
        BarrierRounds(swarm, key=3, need=1, every=0.3, start=1.1, renew=True).install()
    RoleChurn(swarm, case.seed, quota=1).install()
    AppChatter(swarm, case.seed).install()

    def apply(action: Action) -> None:
        if action.kind == "crash":
            swarm.crash(action.args[0])
        elif action.kind == "restart":
            swarm.restart(action.args[0])
        elif action.kind == "partition":
            swarm.partition([action.args[0]])
        else:
            swarm.heal()

    for action in case.actions:
        swarm.at(action.t, apply, action)
    swarm.run_until(case.faults_until)
    # Quiet period: whole network, everyone back, clean radio.
    swarm.heal()
    for p in range(1, case.size + 1):
        if p not in swarm.nodes:
            swarm.restart(p)
    swarm.radio.model = LinkModel(latency=case.link.latency)
    quiet_start = swarm.now
    swarm.run_until(end)
    violations = swarm.finish()
    result = CaseResult(case, violations)
    nodes = swarm.nodes
    masters = swarm.current_masters()
    if len(masters) != 1:
        result.problems.append(f"{len(masters)} masters after the quiet period: {masters}")
    else:
        m = masters[0]
        epoch = nodes[m].epoch
        lost = sorted(p for p, n in nodes.items() if n.master != m or n.epoch != epoch)
        if lost:
            result.problems.append(
                f"platforms {lost} do not follow master {m} in epoch {epoch}: "
                + ", ".join(f"{p}->{nodes[p].master}@{nodes[p].epoch}" for p in lost)
            )
        missing = sorted(set(nodes) - set(nodes[m].view))
        if missing:
            result.problems.append(f"master {m}'s view lacks live platforms {missing}")
        if not nodes[m].handshake_complete:
            result.problems.append(f"master {m}'s handshake never completed")
    result.fired_after_quiet = sum(
        1 for e in swarm.log if e.t >= quiet_start + 2.0 and isinstance(e.event, BarrierFired)
    )
    if result.fired_after_quiet == 0:
        result.problems.append("no barrier fired in the last seconds of the quiet period")
    return result
