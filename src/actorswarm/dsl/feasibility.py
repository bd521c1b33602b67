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

Branch counts bound the holders too (:func:`most_holders`): every platform that ever runs an
actor started in one of the actors that lead to it, and a platform that started in an actor
no transition re-enters (a *closed* actor) can only have left it through that actor's
transitions. As for reachability, the group's own successors do not count as re-entering:
until the group first fired they bring nobody back, so an actor that only the group's
release re-enters is closed for the group's bound. A ``sysNum="all"`` transition out of
a closed actor fires once (it takes every holder, and none can come back), so its branch
of ``cnt="4"`` sends 4 platforms in all; a numeric ``sysNum`` n out of a closed actor
started on N platforms fires at most N // n times.
So in "take off, then 4 to Escort and the rest to Search", at most 4 platforms can ever run
Escort, and a transition of Escort with ``sysNum="6"`` can never fire.

The check is *necessary, not sufficient*: it assumes any platform that can ever hold an actor
might hold it when the group fires, and knows nothing of timing, bids or platforms leaving
(nor of a platform that misses a ``sysNum="all"`` firing, cut off from the master, and takes
the transition again later). So an error here means "can never fire", while passing means
only "might fire".
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Hashable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace

from actorswarm.dsl.model import Position, TaskScript, Transition
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
    #: Where to point (None: the group's first transition).
    where: Position | None = None
    #: Not an error: the group can fire, but one of its transitions never takes part.
    warning: bool = False


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


def most_holders(
    script: TaskScript, graph: Mapping[str, set[str]], *, without: Iterable[Transition] = ()
) -> dict[str, int]:
    """An upper bound on the platforms that can ever run each actor reachable in ``graph``
    (the edges of :func:`edges` made ``without`` the same transitions), from the branch
    counts of the transitions out of *closed* actors (see the module docstring); an actor
    that no bound applies to is left out.

    Every platform thread is counted in the actor it starts in: a thread started in ``x``
    can run ``y`` only if ``y`` is reachable from ``x``. A thread that starts in ``y`` itself,
    or in an actor that something re-enters, counts in full; one that starts in a closed
    actor ``x`` counts only as far as the branches out of ``x`` towards ``y`` carry it.
    """
    skipped = {id(t) for t in without}
    started = {actor: len(ids) for actor, ids in script.initial_actors().items()}
    entered = {successor for targets in graph.values() for successor in targets}
    # What may leave each closed actor through each of its edges, in all.
    carry: dict[str, dict[str, int]] = {}
    for actor, count in started.items():
        if actor in entered:
            continue
        out: dict[str, int] = defaultdict(int)
        for transition in script.transitions.get(actor, ()):
            if transition.timeout_branch is not None:
                out[transition.timeout_branch] += count
            if id(transition) in skipped:
                continue
            for branch in transition.branches:
                out[branch.successor] += _branch_carry(transition, branch.count, count)
        carry[actor] = {target: min(n, count) for target, n in out.items()}
    reverse: dict[str, set[str]] = defaultdict(set)
    for source, targets in graph.items():
        for target in targets:
            reverse[target].add(source)
    bounds: dict[str, int] = {}
    for actor in reachable(graph, started):
        leads_here = reachable(reverse, [actor])
        total = 0
        for origin, count in started.items():
            if origin not in leads_here:
                continue
            if origin == actor or origin not in carry:
                total += count
            else:
                sent = sum(n for target, n in carry[origin].items() if target in leads_here)
                total += min(sent, count)
        bounds[actor] = total
    return bounds


def _branch_carry(transition: Transition, count: int | str, holders: int) -> int:
    """How many platforms one branch of ``transition`` can send in all, out of a closed
    actor started on ``holders`` platforms."""
    fixed = sum(b.count for b in transition.branches if b.count != "rest")
    if transition.sys_num == "all":
        firings, share = 1, holders - fixed
    else:
        firings, share = holders // transition.sys_num, transition.sys_num - fixed
    return max(0, firings * (count if isinstance(count, int) else share))


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
    #: :func:`most_holders` of the same edges (an actor left out: no bound from counts).
    most: Mapping[str, int] = field(default_factory=dict)

    @classmethod
    def build(
        cls,
        classes: Mapping[frozenset[str], list[int]],
        graph: Mapping[str, set[str]],
        most: Mapping[str, int] | None = None,
    ) -> Reach:
        # What a thread started in x can reach depends on x alone, not on its platform.
        reach = {x: reachable(graph, [x]) for x in frozenset().union(*classes)}
        holders: dict[str, list[int]] = defaultdict(list)
        for signature, ids in classes.items():
            for actor in set().union(*(reach[x] for x in signature)):
                holders[actor].extend(ids)
        return cls(classes, reach, holders, dict(most or {}))

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
    empty = [t for t in group.members if not swarm.holders.get(t.actor)]
    if empty and len(empty) < len(group.members):
        # A transition whose actor nobody can be running while the group waits has no
        # candidates and holds the group back from nothing: the rest decide.
        rest = Group(group.key, tuple(t for t in group.members if t not in empty))
        found = check_group(rest, swarm, everywhere)
        if found is not None:
            return Infeasible(group, found.message, found.where, found.warning)
        quiet = [t for t in empty if t.actor in everywhere]  # else "never runs" says it
        if not quiet:
            return None
        t = quiet[0]
        return Infeasible(
            group,
            f"{t.event} of {t.actor} never takes part in {what}: {t.actor} is only entered "
            "through this group itself, so no platform runs it while the group waits, and "
            "the group fires without it",
            t.pos,
            warning=True,
        )
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
    for transition in group.members:
        need = demand(transition)
        most = swarm.most.get(transition.actor)
        if not most or most >= need:
            continue  # 0: nothing ever sends a platform there, which is said where it starts
        at_least = "at least " if transition.sys_num == "all" else ""
        role = "" if group.key is None else f" (for {transition.event} of {transition.actor})"
        only = (
            f"; it would only ever end by its timeout of {transition.timeout:g} s"
            if transition.timeout is not None
            else ""
        )
        return Infeasible(
            group,
            f"{what} can never fire: it needs {at_least}{need} platforms running "
            f"{transition.actor} at once{role}, but the branch counts of the transitions "
            f"that lead to it let at most {most} ever run it{only}; lower sysNum to at most "
            f"{most} or send more platforms to {transition.actor}",
            transition.at("sysNum"),
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
    full = Reach.build(classes, graph, most_holders(script, graph))
    for group in groups(script):
        # Leaving out the edges *from* a lone transition's own actor cannot change whether
        # that actor is reached, so only a group of several needs its own reachability. The
        # bound from counts can change, though: an actor re-entered only through the group's
        # own release is closed until the group first fired (a cycle back through the group
        # does not bring anybody before that).
        if len(group.members) == 1:
            without = edges(script, without=group.members)
            most = most_holders(script, without, without=group.members)
            swarm = full if most == full.most else replace(full, most=most)
        else:
            without = edges(script, without=group.members)
            swarm = Reach.build(
                classes, without, most_holders(script, without, without=group.members)
            )
        found = check_group(group, swarm, everywhere)
        if found is not None:
            yield found
