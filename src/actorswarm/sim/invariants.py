"""The invariants every simulated run is checked against, reported as readable strings.

Theory of operation
-------------------
The checker is omniscient — it sees every platform's events and state and the radio's
partitions — but only *observes*: it never changes a run. Hosts feed it events as they are
drained (:meth:`InvariantChecker.on_event`), let it sample state periodically
(:meth:`InvariantChecker.sample`), and call :meth:`InvariantChecker.finish` at the end.

The invariants (docs/design.md §3, issue "collective core"):

1. **One master per connected component once the network is stable**: two masters may meet
   for a moment (a partition heals, a false suspicion under loss); a component with more
   than one master for longer than ``settle`` seconds is a violation.
2. **Barrier releases are all-or-nothing**: once a participant of a barrier generation
   passed it, every chosen participant of that firing that is still alive (same
   incarnation) and connected to a live one that passed, must pass it too (checked at the
   end, for firings older than ``settle``). A pass counts for the firing that gave the
   platform its place in that incarnation, not for another firing of the same generation.
   A platform passes a generation at most once, and only with the index a firing gave it.
3. **A role quota is never exceeded** among live platforms of one component for longer than
   ``settle`` (a false suspicion under loss may overlap a revoked and a new holder briefly).
4. **No message reaches the application twice** (app messages, barrier releases).
5. **Epochs never go backwards** on any platform incarnation.
6. **No internal error** was caught at a platform's packet boundary.
7. **A barrier of all leaves no one out**: a master that fires a key every request of which
   waits for all (``all_keys``, NEED_ALL) chooses every platform of its view, itself
   included (a complete firing; a timeout or the completion of a predecessor's firing
   chooses whom it can).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

from actorswarm.core.events import (
    AppReceived,
    BarrierFired,
    BarrierReleased,
    CoreEvent,
    MasterChanged,
)
from actorswarm.core.node import Node


@dataclass(slots=True)
class _Firing:
    epoch: int
    at: float
    chosen: dict[int, tuple[int, int]]
    incarnations: dict[int, int]


@dataclass(slots=True)
class InvariantChecker:
    """Collects violations of the core's invariants over one run."""

    settle: float
    incarnation_of: Callable[[int], int]
    #: When a platform's current incarnation booted (a master may still count a request of
    #: the previous incarnation until it notices the reboot).
    booted_at: Callable[[int], float] = lambda p: 0.0
    #: How long a master may not know of a reboot (a leave, then a join).
    reboot_blindness: float = 0.0
    #: Keys whose every request waits for all (NEED_ALL): invariant 7. Workloads add theirs.
    all_keys: set[int] = field(default_factory=set)
    violations: list[str] = field(default_factory=list)
    _epochs: dict[tuple[int, int], int] = field(default_factory=dict)
    _firings: dict[tuple[int, int], list[_Firing]] = field(default_factory=dict)
    _passed: dict[tuple[int, int], dict[tuple[int, int], tuple[int, int]]] = field(
        default_factory=dict
    )
    _apps: set[tuple[int, ...]] = field(default_factory=set)
    _multi_master_since: dict[frozenset[int], float] = field(default_factory=dict)
    _quota_since: dict[tuple[frozenset[int], str], float] = field(default_factory=dict)
    _reported: set[str] = field(default_factory=set)

    def _violate(self, t: float, text: str, *, once: str | None = None) -> None:
        if once is not None:
            if once in self._reported:
                return
            self._reported.add(once)
        self.violations.append(f"t={t:.3f}s: {text}")

    def on_event(self, t: float, node: Node, event: CoreEvent) -> None:
        """Account for one event drained from ``node`` at virtual time ``t``."""
        who = (node.platform, node.incarnation)
        if isinstance(event, MasterChanged):
            last = self._epochs.get(who, 0)
            if event.epoch < last:
                self._violate(
                    t,
                    f"platform {node.platform} (incarnation {node.incarnation}) went back "
                    f"from epoch {last} to {event.epoch}",
                )
            self._epochs[who] = max(last, event.epoch)
        elif isinstance(event, BarrierFired):
            if event.key in self.all_keys and event.outcome == "complete" and not event.completion:
                left_out = {node.platform, *node.members.peers} - event.chosen.keys()
                if left_out:
                    self._violate(
                        t,
                        f"master {node.platform} fired barrier {event.key}/{event.generation} "
                        f"of all (epoch {event.epoch}) without {sorted(left_out)} of its view",
                    )
            self._firings.setdefault((event.key, event.generation), []).append(
                _Firing(
                    event.epoch,
                    t,
                    dict(event.chosen),
                    {p: self.incarnation_of(p) for p in event.chosen},
                )
            )
        elif isinstance(event, BarrierReleased):
            passed = self._passed.setdefault((event.key, event.generation), {})
            if who in passed:
                self._violate(
                    t,
                    f"platform {node.platform} passed barrier {event.key}/{event.generation} twice",
                )
            passed[who] = (event.part, event.index)
            if event.chosen:
                firings = self._firings.get((event.key, event.generation), [])
                if not any(
                    f.chosen.get(node.platform) == (event.part, event.index) for f in firings
                ):
                    self._violate(
                        t,
                        f"platform {node.platform} passed barrier {event.key}/"
                        f"{event.generation} as #{event.index} of part {event.part}, "
                        "which no firing assigned",
                    )
        elif isinstance(event, AppReceived) and event.stream is not None:
            key = (*who, event.sender, *event.stream)
            if key in self._apps:
                self._violate(
                    t,
                    f"platform {node.platform} got app message {event.topic!r} from "
                    f"{event.sender} twice",
                )
            self._apps.add(key)

    def sample(
        self,
        t: float,
        nodes: Mapping[int, Node],
        components: Callable[[Iterable[int]], list[frozenset[int]]],
    ) -> None:
        """Check the state invariants (masters, quotas) over the live ``nodes`` at ``t``."""
        if sum(node.is_master for node in nodes.values()) <= 1 and not any(
            node.roles.held for node in nodes.values()
        ):
            # Nothing any component could violate: no two masters, no role held. Splitting
            # the swarm into components asks the radio about every pair (435 pairs at 30
            # platforms, ten times a second), most of a run's invariant cost.
            self._multi_master_since.clear()
            self._quota_since.clear()
            return
        comps = components(nodes)
        live_multi: set[frozenset[int]] = set()
        live_quota: set[tuple[frozenset[int], str]] = set()
        for comp in comps:
            masters = [p for p in comp if nodes[p].is_master]
            if len(masters) > 1:
                live_multi.add(comp)
                since = self._multi_master_since.setdefault(comp, t)
                if t - since > self.settle:
                    self._violate(
                        t,
                        f"{len(masters)} masters {sorted(masters)} in one component of "
                        f"{len(comp)} platforms for {t - since:.2f}s (> {self.settle}s)",
                        once=f"multi:{sorted(comp)}:{since}",
                    )
            holders: dict[str, list[int]] = {}
            quotas: dict[str, int] = {}
            for p in comp:
                for role, claim in nodes[p].roles.held.items():
                    holders.setdefault(role, []).append(p)
                    quotas[role] = min(quotas.get(role, claim.quota), claim.quota)
            for role, who in holders.items():
                if len(who) > quotas[role]:
                    live_quota.add((comp, role))
                    since = self._quota_since.setdefault((comp, role), t)
                    if t - since > self.settle:
                        self._violate(
                            t,
                            f"role {role!r} held by {sorted(who)} (quota {quotas[role]}) "
                            f"for {t - since:.2f}s (> {self.settle}s)",
                            once=f"quota:{role}:{since}",
                        )
        for comp in set(self._multi_master_since) - live_multi:
            del self._multi_master_since[comp]
        for item in set(self._quota_since) - live_quota:
            del self._quota_since[item]

    def finish(
        self,
        t: float,
        nodes: Mapping[int, Node],
        components: Callable[[Iterable[int]], list[frozenset[int]]],
    ) -> list[str]:
        """Run the end-of-run checks; return every violation found over the run."""
        comp_of: dict[int, frozenset[int]] = {}
        for comp in components(nodes):
            for p in comp:
                comp_of[p] = comp
        for (key, gen), firings in sorted(self._firings.items()):
            passed = self._passed.get((key, gen), {})
            if not passed:
                continue  # nothing was released: "nothing" is a valid outcome
            passed_platforms = {p for p, _ in passed}
            for f in firings:
                if t - f.at < self.settle:
                    continue
                # The passes this firing caused: by a platform still alive in the incarnation
                # the firing chose, with the place the firing gave it. When everyone who
                # passed has since crashed, no live platform can know the firing happened.
                # One generation may fire twice: a master fires it, nobody hears the release
                # before it crashes, and its successor fires the generation again for whoever
                # asks; a pass of the second firing says nothing of the first.
                effective = {
                    p
                    for (p, inc), place in passed.items()
                    if f.chosen.get(p) == place
                    and f.incarnations.get(p) == inc
                    and p in nodes
                    and nodes[p].incarnation == inc
                }
                if not effective:
                    continue
                reach: set[int] = set()
                for p in effective:
                    reach |= comp_of.get(p, frozenset())
                for p in sorted(f.chosen):
                    node = nodes.get(p)
                    if node is None or node.incarnation != f.incarnations.get(p, node.incarnation):
                        continue
                    if self.booted_at(p) > f.at - self.reboot_blindness:
                        continue  # the firing may have counted its previous incarnation
                    if p in reach and p not in passed_platforms:
                        self._violate(
                            t,
                            f"partial release of barrier {key}/{gen}: platform {p} was chosen "
                            f"(epoch {f.epoch}) and is alive and connected, but never passed",
                        )
        for p, node in sorted(nodes.items()):
            for err in node.errors:
                self._violate(t, f"platform {p} caught an internal error: {err}")
        return list(self.violations)
