"""Can each barrier group ever fire with the platforms the script starts?

A *group* is every transition sharing one ``barrierKey`` (a transition without a key is a
group of its own). It fires only when each of its transitions has its ``sysNum`` candidates
at the same moment (docs/design.md §4), so the question is whether the platforms of
``<_PlatformActorConfig>`` could ever hold all those actors at once.

The model of a platform: each of its ``<platform>`` lines starts one *thread* of actors on
it; a transition moves a thread from one actor to another, so a thread that starts in ``x``
can only ever be in an actor reachable from ``x``. One thread is in one actor at a time, and
a platform runs an actor at most once, so a platform is at most one candidate per
transition, and each of its threads serves at most one transition of the group.

For a group, reachability uses every transition *except the group's own successors*: the
group's holders must exist before it fires, so an actor entered only through the group
itself can never provide its candidates (the "cycle that can never fire"). Timeout edges of
the group do count — a timeout releases candidates without the group firing.

Whether the demands can be met together is then a bipartite assignment of threads to
transitions, solved as a maximum flow::

    source -> transition i          capacity: its demand (sysNum; for "all", the integer
                                    branch counts, at least 1)
    transition i -> (i, class c)    capacity: size of c (one candidate per platform)
    (i, c) -> thread (c, x)         when a thread of c started in x can reach i's actor
    thread (c, x) -> sink           capacity: size of c (one transition per thread)

Platforms with the same set of lines form one *class* c and are handled together, which
keeps the network small even for 65535 platforms; splitting the flow of a class back into
single platforms is always possible (a bipartite multigraph of degree at most ``|c|`` splits
into ``|c|`` matchings, König). When the maximum flow is below the total demand, no moment
exists at which the group could fire.

The check is *necessary, not sufficient*: it assumes any platform that can ever hold an actor
might hold it when the group fires, and knows nothing of timing, bids or platforms leaving.
So an error here means "can never fire", while passing means only "might fire".
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Hashable, Iterable, Iterator, Mapping
from dataclasses import dataclass

from actorswarm.dsl.model import TaskScript, Transition
from actorswarm.dsl.syntax import id_ranges


@dataclass(frozen=True, slots=True)
class Group:
    """The transitions sharing barrier ``key`` (None: one transition without a key)."""

    key: int | None
    members: tuple[Transition, ...]

    def describe(self) -> str:
        if self.key is not None:
            return f"barrier group {self.key}"
        member = self.members[0]
        return f"transition {member.event} of actor {member.actor}"


@dataclass(frozen=True, slots=True)
class Infeasible:
    """A group that can never fire, and why (a sentence to put after ``file:line:col:``)."""

    group: Group
    message: str


def groups(script: TaskScript) -> list[Group]:
    """Every group, in the order its first transition appears in the script."""
    keyed: dict[int, list[Transition]] = {}
    found: list[Group | int] = []
    for transition in script.all_transitions():
        if transition.barrier_key is None:
            found.append(Group(None, (transition,)))
        elif transition.barrier_key in keyed:
            keyed[transition.barrier_key].append(transition)
        else:
            keyed[transition.barrier_key] = [transition]
            found.append(transition.barrier_key)
    return [g if isinstance(g, Group) else Group(g, tuple(keyed[g])) for g in found]


def demand(transition: Transition) -> int:
    """How many holders of its actor ``transition`` needs at once to fire."""
    if transition.sys_num != "all":
        return transition.sys_num
    fixed = sum(b.count for b in transition.branches if b.count != "rest")
    return max(1, fixed)


def edges(script: TaskScript, *, without: Iterable[Transition] = ()) -> dict[str, set[str]]:
    """``{actor: actors one transition away}``: successors of every transition not in
    ``without``, and the ``timeoutBranch`` of every transition."""
    skipped = {id(t) for t in without}
    graph: dict[str, set[str]] = defaultdict(set)
    for transition in script.all_transitions():
        if id(transition) not in skipped:
            graph[transition.actor].update(transition.successors)
        if transition.timeout_branch is not None:
            graph[transition.actor].add(transition.timeout_branch)
    return graph


def reachable(graph: Mapping[str, set[str]], starts: Iterable[str]) -> set[str]:
    """Every actor reachable in ``graph`` from ``starts`` (including them)."""
    seen = set(starts)
    todo = deque(seen)
    while todo:
        for successor in graph.get(todo.popleft(), ()):
            if successor not in seen:
                seen.add(successor)
                todo.append(successor)
    return seen


def platform_classes(script: TaskScript) -> dict[frozenset[str], list[int]]:
    """Platforms grouped by the set of actors their lines start (``{actors: [ids]}``)."""
    started: dict[int, set[str]] = defaultdict(set)
    for line in script.platforms:
        for platform in line.ids:
            started[platform].add(line.actor)
    classes: dict[frozenset[str], list[int]] = defaultdict(list)
    for platform in sorted(started):
        classes[frozenset(started[platform])].append(platform)
    return dict(classes)


def max_flow(
    capacity: Mapping[Hashable, Mapping[Hashable, int]], source: Hashable, sink: Hashable
) -> int:
    """The maximum flow from ``source`` to ``sink`` (Edmonds-Karp; the networks are small)."""
    residual: dict[Hashable, dict[Hashable, int]] = defaultdict(dict)
    for u, targets in capacity.items():
        for v, cap in targets.items():
            residual[u][v] = residual[u].get(v, 0) + cap
            residual[v].setdefault(u, 0)
    total = 0
    while True:
        parent: dict[Hashable, Hashable] = {source: source}
        todo = deque([source])
        while todo and sink not in parent:
            u = todo.popleft()
            for v, cap in residual[u].items():
                if cap > 0 and v not in parent:
                    parent[v] = u
                    todo.append(v)
        if sink not in parent:
            return total
        path: list[tuple[Hashable, Hashable]] = []
        v = sink
        while v != source:
            path.append((parent[v], v))
            v = parent[v]
        push = min(residual[u][v] for u, v in path)
        for u, v in path:
            residual[u][v] -= push
            residual[v][u] += push
        total += push


def _short(ids: Iterable[int]) -> str:
    text = id_ranges(frozenset(ids))
    return text if len(text) <= 40 else text[:37] + "..."


@dataclass(frozen=True, slots=True)
class Reach:
    """The platforms of a script, seen from one group: ``classes`` (platforms grouped by
    the actors their lines start), what a thread started in each actor can ``reach`` before
    the group fires, and the ``holders`` of each actor (platforms that can ever run it)."""

    classes: Mapping[frozenset[str], list[int]]
    reach: Mapping[str, set[str]]
    holders: Mapping[str, list[int]]

    @classmethod
    def build(
        cls, classes: Mapping[frozenset[str], list[int]], graph: Mapping[str, set[str]]
    ) -> Reach:
        # What a thread started in x can reach depends on x alone, not on its platform.
        reach = {x: reachable(graph, [x]) for x in frozenset().union(*classes)}
        holders: dict[str, list[int]] = defaultdict(list)
        for signature, ids in classes.items():
            for actor in set().union(*(reach[x] for x in signature)):
                holders[actor].extend(ids)
        return cls(classes, reach, holders)

    def network(self, group: Group) -> dict[Hashable, dict[Hashable, int]]:
        """The flow network of ``group`` (see the module docstring)."""
        capacity: dict[Hashable, dict[Hashable, int]] = defaultdict(dict)
        for i, transition in enumerate(group.members):
            capacity["source"][("t", i)] = demand(transition)
            for signature, ids in self.classes.items():
                threads = [x for x in signature if transition.actor in self.reach[x]]
                if threads:
                    capacity[("t", i)][("tc", i, signature)] = len(ids)
                for x in threads:
                    capacity[("tc", i, signature)][("th", signature, x)] = len(ids)
                    capacity[("th", signature, x)]["sink"] = len(ids)
        return capacity


def check_group(group: Group, swarm: Reach, everywhere: set[str]) -> Infeasible | None:
    """Why ``group`` can never fire, or None when it might.

    ``swarm`` is the reachability before the group fires; ``everywhere`` is every actor any
    platform can ever run (a group made only of actors no platform runs is left to the
    "never runs" warning).
    """
    if all(t.actor not in everywhere for t in group.members):
        return None
    what = group.describe()
    for transition in group.members:
        need = demand(transition)
        platforms = swarm.holders.get(transition.actor, [])
        if len(platforms) >= need:
            continue
        at_least = "at least " if transition.sys_num == "all" else ""
        role = "" if group.key is None else f" (for {transition.event} of {transition.actor})"
        if not platforms:
            why = (
                f"{transition.actor} is only entered through this group itself"
                if transition.actor in everywhere
                else f"no platform ever runs {transition.actor}"
            )
            return Infeasible(
                group,
                f"{what} can never fire: it needs {at_least}{need} platform"
                f"{'s' if need != 1 else ''} running {transition.actor}{role}, but no platform "
                f"can be running it before the group fires ({why}); start {transition.actor} "
                "on some platforms or reach it through another transition",
            )
        return Infeasible(
            group,
            f"{what} can never fire: it needs {at_least}{need} platforms running "
            f"{transition.actor} at once{role}, but only {len(platforms)} can ever run it "
            f"({_short(platforms)}); lower sysNum to at most {len(platforms)} or start more "
            "platforms",
        )
    if len(group.members) == 1:
        return None  # one transition: the holder count above is exact
    total = sum(demand(t) for t in group.members)
    flow = max_flow(swarm.network(group), "source", "sink")
    if flow >= total:
        return None
    needs = ", ".join(f"{demand(t)} running {t.actor} for {t.event}" for t in group.members)
    pool = {p for t in group.members for p in swarm.holders.get(t.actor, [])}
    return Infeasible(
        group,
        f"{what} can never fire: its transitions need {total} platforms at once ({needs}), "
        f"but at most {flow} of the platforms that can run those actors ({_short(pool)}) can "
        "take part together; lower the sysNum values or start more platforms",
    )


def infeasible_groups(script: TaskScript) -> Iterator[Infeasible]:
    """Every group of ``script`` that can never fire (see the module docstring)."""
    classes = platform_classes(script)
    graph = edges(script)
    everywhere = reachable(graph, script.initial_actors())
    full = Reach.build(classes, graph)
    for group in groups(script):
        # Leaving out the edges *from* a lone transition's own actor cannot change whether
        # that actor is reached, so only a group of several needs its own reachability.
        swarm = (
            full
            if len(group.members) == 1
            else Reach.build(classes, edges(script, without=group.members))
        )
        found = check_group(group, swarm, everywhere)
        if found is not None:
            yield found
