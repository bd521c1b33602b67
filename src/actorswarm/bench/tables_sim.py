"""The paper's Tables I–III in the simulator: task engines, actor runtimes and core nodes of
every platform in one process, over the simulated radio, in virtual time.

Timings of Tables II and III are virtual: they depend on the protocol and the radio model
(:func:`radio_model`), not on the machine, and a run is replayed exactly from its seed.
Table I's CPU figure and switch times are wall-clock measurements of this process.

* **Table I**: a swarm of ``peers + 1`` platforms alternating A ⇄ B at 1 Hz
  (:func:`~actorswarm.bench.scripts.table1_script`); each repetition runs ``window``
  virtual seconds and reports the process CPU time spent per platform per virtual second
  (% of one core: an upper bound of one platform's protocol + runtime cost, the simulated
  radio included) and the runtime's switch times (switch call → end of the new actor's
  first OODA step, wall clock) of every platform.
* **Table II**: one swarm per size, plugin count and loss; each repetition the ground
  station (platform 0, over the radio) sends the event — ``go``/``back`` alternately to
  every platform for ``switch``, ``split`` to two platforms drawn from the seeded generator
  for ``branch`` (then ``rejoin``, unmeasured). Transition time: the event sent → the last
  platform's transition. Traffic: every platform's packets sent + received over the same
  window, at the master and averaged over every non-master; bytes per packet over every
  packet sent in the window.
* **Table III**: :func:`actorswarm.bench.core.run_failover` — the master crashes at a random
  heartbeat phase (in a swarm in which every platform has the whole swarm in its view); the
  time until a new master has every survivor in its view and each of them reported to it.

Tables II and III run the collective core with :attr:`SimBackend.membership` (the row
records it); Table I with the core's default.
"""

from __future__ import annotations

import random
import statistics
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field, replace

from actorswarm.bench.core import run_failover
from actorswarm.bench.scripts import (
    BACK,
    GO,
    REJOIN,
    SPLIT,
    actor_names,
    table1_script,
    table2_script,
)
from actorswarm.bench.tables import (
    Plan,
    Progress,
    Rows,
    Table1Row,
    Table2Row,
    Table2Sample,
    Table3Row,
    TableSettings,
    quiet,
    record_sample,
    table1_units,
)
from actorswarm.core.config import CoreConfig, MembershipKind
from actorswarm.dsl import check
from actorswarm.dsl.model import TaskScript
from actorswarm.engine import commands as cmds
from actorswarm.engine.records import FiredRecord
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import TaskSim

__all__ = [
    "SimBackend",
    "radio_model",
    "sim_table1",
    "sim_table2_cell",
    "sim_table3",
]

NAN = float("nan")
#: Virtual time after a transition before the next: its last acknowledgements land (an
#: unacknowledged release is retransmitted within 200 ms).
SETTLE = 0.3
#: From this size on a row is repeated ``big_repeat`` times (beyond the paper's sizes).
BIG = 100


@dataclass(frozen=True, slots=True)
class SimBackend:
    """The tables in the simulator (a :class:`~actorswarm.bench.tables.Backend`): how much
    to measure, and the simulated radio, the membership scheme and the repetitions beyond
    the paper's sizes. Times are seconds (virtual unless said otherwise)."""

    settings: TableSettings = field(default_factory=TableSettings)
    #: Repetitions at the sizes beyond the paper's (≥ 100): a 1000-platform swarm runs at
    #: about 100 s of wall time per simulated second on a 2-core machine, so forming it
    #: and one repetition take 5–10 minutes (much longer under heavy loss).
    big_repeat: int = 3
    #: One-way radio latency of every link, and the extra delay drawn in [0, jitter] per
    #: packet and receiver.
    latency: float = 0.01
    jitter: float = 0.005
    #: A transition that has not reached every platform after this long failed.
    run_timeout: float = 30.0
    #: A swarm with no master that has everyone in its view this long after boot is
    #: reported as not formed (1000 platforms under 30 % loss: members are falsely declared
    #: gone faster than they rejoin).
    settle_timeout: float = 15.0
    #: Tables II and III: the core's membership scheme (``CoreConfig.membership``): "star"
    #: (members heartbeat to the master only) or "broadcast" (everyone to everyone).
    membership: MembershipKind = "star"

    @property
    def mode(self) -> str:
        return "sim"

    def repeats(self, size: int) -> int:
        return self.big_repeat if size >= BIG else self.settings.repeat

    def units(self, plan: Plan) -> int:
        """One per repetition of every row of ``plan``, in each of its membership schemes."""
        schemes = len(plan.memberships)
        units = table1_units(plan.plugins, self.settings) if "1" in plan.tables else 0
        if "2" in plan.tables:
            units += schemes * sum(self.repeats(size) for _, size, _, _ in plan.cells2)
        if "3" in plan.tables:
            units += schemes * sum(self.repeats(size) for size, _ in plan.cells3)
        return units

    def rows(self, plan: Plan, progress: Progress) -> Iterator[Rows]:
        """Table I, then one cell at a time (each is seeded by itself), so the rows so far
        are saved; the schemes of one cell run one after the other, so a run cut short has
        pairs."""
        if "1" in plan.tables:
            yield sim_table1(plan.plugins, self, progress)
        for cell in plan.cells2 if "2" in plan.tables else []:
            for scheme in plan.memberships:
                yield [sim_table2_cell(*cell, replace(self, membership=scheme), progress)]
        for cell3 in plan.cells3 if "3" in plan.tables else []:
            for scheme in plan.memberships:
                yield sim_table3([cell3], replace(self, membership=scheme), progress)


def radio_model(backend: SimBackend, config: CoreConfig | None = None) -> dict[str, object]:
    """What the simulated rows depend on, for the report."""
    config = config or CoreConfig()
    return {
        "latency_ms": backend.latency * 1000,
        "jitter_ms": backend.jitter * 1000,
        "loss": "independent per packet and receiver, at the row's rate",
        "heartbeat_ms": config.heartbeat_interval * 1000,
        "t_leave_ms": config.t_leave * 1000,
        "retransmit_ms": f"{config.retry_base * 1000:g} + k·{config.retry_step * 1000:g} "
        f"(cap {config.retry_cap * 1000:g})",
        "authentication": "every packet sealed and checked by the receiver's guard, as on a "
        "daemon (keys derived from the seed)",
    }


def replay_command(table: str, size: int, loss: float, backend: SimBackend, **only: object) -> str:
    """The command that measures this row again, exactly (same seed, same repetitions, same
    membership scheme — named even when it is the default, so the command keeps its meaning
    if the default changes);
    ``only`` adds options (Table II's ``cases`` and ``plugins``). Nothing else is measured
    but, for a lossy row, the loss-free row of the same size, which comes first."""
    repeat = "--big-repeat" if size >= BIG else "--repeat"
    parts = [f"actorswarm bench {table} --mode sim --sizes {size} --big-sizes ''"]
    parts += [f"--{k} {v}" for k, v in only.items()]
    parts += [f"--loss {loss:g}" if loss else "--loss ''"]
    parts += [f"{repeat} {backend.repeats(size)} --seed {backend.settings.seed}"]
    parts += [f"--membership {backend.membership}"]
    return " ".join(parts)


def _script(text: str) -> TaskScript:
    result = check(text, path="bench.xml")
    if result.script is None:  # the generators are tested; this is a programming error
        raise AssertionError("\n".join(str(d) for d in result.diagnostics))
    return result.script


def _settled(sim: TaskSim, size: int, limit: float) -> bool:
    """Run until one master has everyone in its view with its handshake done."""
    swarm = sim.swarm
    end = swarm.now + limit
    while swarm.now < end:
        sim.advance(swarm.now + 0.05)
        if swarm.formed(size):
            # Quiet for T_join: the master holds back stale notices that long after the
            # swarm changed (a report on its way could still explain a request), which
            # would delay the first transitions by up to a second.
            sim.advance(swarm.now + sim.config.t_join + 0.3)
            return True
    return False


# --- Table I -------------------------------------------------------------------------------


def sim_table1(
    plugins: Sequence[int], backend: SimBackend, progress: Progress = quiet
) -> list[Table1Row]:
    rows = []
    size = backend.settings.peers + 1
    for count in plugins:
        row = Table1Row(mode="sim", plugins=count, peers=backend.settings.peers)
        sim = TaskSim(
            _script(table1_script(size, count)),
            seed=backend.settings.seed,
            link=LinkModel(latency=backend.latency, jitter=backend.jitter),
        )
        progress(f"sim table I: {size} platforms, {count} plugin(s), starting")
        sim.advance(3.0)  # boot: startup wait, joins, election
        for host in sim.hosts.values():
            host.engine.runtime.drain_switch_times()
        for r in range(backend.settings.repeat):
            progress(f"sim table I: {count} plugin(s), window {r + 1}/{backend.settings.repeat}")
            began = time.process_time()
            sim.advance(sim.swarm.now + backend.settings.window)
            used = time.process_time() - began
            row.cpu_pct.append(100.0 * used / (size * backend.settings.window))
            for host in sim.hosts.values():
                row.switch_ms += [s * 1000 for s in host.engine.runtime.drain_switch_times()]
            progress(f"sim table I: {count} plugin(s), window {r + 1}", advance=1)
        rows.append(row)
    return rows


# --- Table II ------------------------------------------------------------------------------


def _totals(sim: TaskSim) -> dict[int, tuple[int, int, int, int]]:
    traffic = sim.swarm.radio.traffic
    return {p: traffic.totals(p) for p in [0, *sim.swarm.nodes]}


def _fire(
    sim: TaskSim,
    event: tuple[str, str, str],
    targets: Iterable[int],
    timeout: float,
) -> tuple[Table2Sample | None, str]:
    """Send ``event`` from the ground station to ``targets`` and run until each of them has
    switched (or ``timeout``). The sample, or None and why not."""
    name, _, dst = event
    targets = sorted(targets)
    swarm = sim.swarm
    masters = swarm.current_masters()
    if len(masters) != 1:
        return None, f"not one master before {name}: {masters}"
    master = masters[0]
    before = _totals(sim)
    sent_at = swarm.now
    sim.operate(lambda gs, now: gs.event(name, now, platforms=targets))
    switched: dict[int, float] = {}
    end = sent_at + timeout
    releases = len(sim.fired)
    while len(switched) < len(targets) and swarm.now < end:
        for rec in sim.advance(swarm.now + 0.002):
            if rec["event"] == name and rec["to"] == dst and rec["platform"] in targets:
                switched.setdefault(rec["platform"], rec["t"])
        behind = _left_out(sim.fired[releases:], targets, switched, swarm.now)
        if behind:
            return None, (
                f"{name}: released to {len(targets) - len(behind)} of {len(targets)}; left "
                f"out {behind} (declared gone during the switch, then not chosen)"
            )
    if len(switched) < len(targets):
        missing = sorted(set(targets) - set(switched))
        return None, f"{name}: {len(switched)} of {len(targets)} switched; missing {missing}"
    last = max(switched.values())
    after = _totals(sim)
    window = max(swarm.now - sent_at, 1e-9)
    moved = {p: [a - b for a, b in zip(after[p], before[p], strict=True)] for p in after}
    members = [p for p in swarm.nodes if p != master]
    master_packets = moved[master][0] + moved[master][2]
    member_packets = (
        statistics.fmean(moved[p][0] + moved[p][2] for p in members) if members else NAN
    )
    sent_packets = sum(d[0] for d in moved.values())
    sent_bytes = sum(d[1] for d in moved.values())
    return (
        Table2Sample(
            transition_ms=(last - sent_at) * 1000,
            master_pps=master_packets / window,
            member_pps=member_packets / window,
            bytes_per_packet=sent_bytes / sent_packets if sent_packets else NAN,
            master_packets=master_packets,
            member_packets=member_packets,
        ),
        "",
    )


def _left_out(
    fired: Sequence[FiredRecord], targets: Sequence[int], switched: dict[int, float], now: float
) -> list[int]:
    """The targets a release left out, once it is clear they will not follow: every chosen
    target has switched and a second has passed (a platform that was declared gone while
    the swarm switched asks again when it rejoins, and is answered "not chosen" — the
    documented semantics). Empty while that is not so. Without it a lossy run at 1000
    platforms waited the whole run timeout, tens of minutes of wall time, per failure."""
    if not fired or now < fired[-1].t + 1.0:
        return []
    chosen = {p for f in fired for p in f.chosen}
    if not all(p in switched for p in targets if p in chosen):
        return []
    return sorted(set(targets) - chosen)


def _record(row: Table2Row, sample: Table2Sample | None, why: str, replay: str) -> None:
    """Append one repetition to every sample list of ``row`` (NaN for a failed one)."""
    record_sample(row, sample)
    if sample is None:
        row.errors.append(f"{why} (replay: {replay})")


def _force(sim: TaskSim, platforms: list[int], actor: str, timeout: float) -> bool:
    """The ground station forces ``platforms`` to ``actor``; run until each runs only it."""
    sim.operate(lambda gs, now: gs.send(cmds.Force(to=actor), platforms, now))
    end = sim.swarm.now + timeout
    while sim.swarm.now < end:
        sim.advance(sim.swarm.now + 0.05)
        if all(list(sim.hosts[p].engine.runtime.running()) == [actor] for p in platforms):
            sim.advance(sim.swarm.now + SETTLE)
            return True
    return False


def sim_table2_cell(
    case: str,
    size: int,
    plugins: int,
    loss: float,
    backend: SimBackend,
    progress: Progress = quiet,
) -> Table2Row:
    """Every repetition of one (case, size, plugins, loss) on one simulated swarm."""
    row = Table2Row(
        mode="sim",
        case=case,
        size=size,
        plugins=plugins,
        loss=loss,
        membership=backend.membership,
    )
    repeats = backend.repeats(size)
    # The same seed in either membership scheme: the two rows differ by the scheme only.
    seed = backend.settings.seed * 1_000_003 + size * 101 + plugins * 7 + round(loss * 100)
    replay = replay_command("table2", size, loss, backend, cases=case, plugins=plugins)
    label = (
        f"sim table II {case} {backend.membership}: N={size}, {plugins} plugin(s), {loss:.0%} loss"
    )
    if case == "branch" and size < 2:
        row.errors.append("branching needs two platforms")
        progress(label, advance=repeats)
        return row
    sim = TaskSim(
        _script(table2_script(size, plugins, timeout=backend.run_timeout)),
        seed=seed,
        link=LinkModel(latency=backend.latency, jitter=backend.jitter, loss=loss),
        config=CoreConfig(membership=backend.membership),
    )
    progress(f"{label}: booting")
    if not _settled(sim, size, backend.settle_timeout):
        why = f"the swarm did not form in {backend.settle_timeout:g} s"
        for _ in range(repeats):
            _record(row, None, why, replay)
        progress(label, advance=repeats)
        return row
    rng = random.Random(seed)
    everyone = sorted(sim.swarm.nodes)
    a, b, c = actor_names(plugins)
    go, back, split, rejoin = (GO[0], a, b), (BACK[0], b, a), (SPLIT[0], a, c), (REJOIN[0], c, a)
    at = a  # where every platform is
    for r in range(repeats):
        progress(f"{label}: {r + 1}/{repeats}")
        if case == "switch":
            event = go if at == a else back
            targets = everyone
            sample, why = _fire(sim, event, targets, backend.run_timeout)
            at = event[2]
            sim.advance(sim.swarm.now + SETTLE)
        else:
            targets = sorted(rng.sample(everyone, 2))
            sample, why = _fire(sim, split, targets, backend.run_timeout)
            if sample is not None:
                sample_back, _ = _fire(sim, rejoin, targets, backend.run_timeout)
                sim.advance(sim.swarm.now + SETTLE)
                if sample_back is None:
                    why = "rejoin did not bring both back"
        _record(row, sample, why, replay)
        if sample is not None and why:
            row.errors.append(f"after repetition {r + 1}: {why} (replay: {replay})")
        progress(label, advance=1)
        # Some platforms left behind (one falsely declared gone misses the release and is
        # then "not chosen"): the operator's forced transition brings them to where the
        # next repetition starts (after the last one, nothing does: at 1000 platforms that
        # saves minutes).
        if r + 1 == repeats:
            break
        if (sample is None or why) and not _force(sim, targets, at, backend.run_timeout):
            for _ in range(r + 1, repeats):
                _record(row, None, f"not run: platforms could not be forced to {at}", replay)
            progress(label, advance=repeats - r - 1)
            break
    return row


# --- Table III -----------------------------------------------------------------------------


def sim_table3(
    cells: Sequence[tuple[int, float]],
    backend: SimBackend,
    progress: Progress = quiet,
) -> list[Table3Row]:
    """For every ``(size, loss)``: the master crashes; the new master is acknowledged."""
    config = CoreConfig(membership=backend.membership)
    rows = []
    for size, loss in cells:
        row = Table3Row(mode="sim", size=size, loss=loss, membership=backend.membership)
        link = LinkModel(latency=backend.latency, jitter=backend.jitter, loss=loss)
        repeats = backend.repeats(size)
        replay = replay_command("table3", size, loss, backend)
        for r in range(repeats):
            progress(
                f"sim table III {backend.membership}: N={size}, {loss:.0%} loss, {r + 1}/{repeats}"
            )
            seed = backend.settings.seed * 1_000_003 + size * 1000 + r
            try:
                run, _ = run_failover(size, seed, link, config)
            except RuntimeError as exc:  # a swarm that never settled
                row.election_ms.append(NAN)
                row.errors.append(f"{exc} (replay: {replay})")
            else:
                row.election_ms.append(run.to_acknowledged * 1000)
                if run.new_master < 0:
                    row.errors.append(
                        f"no new master acknowledged by all in {10 * config.t_leave:g} s "
                        f"(seed {seed}; replay: {replay})"
                    )
            progress(f"sim table III: N={size}", advance=1)
        rows.append(row)
    return rows
