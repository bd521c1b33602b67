"""The meaning checks of a task script, run on the model the builder made.

Two stages, in this order:

:func:`check_references` — rules about single nodes and the names they refer to: duplicate
actor names and IDs, unknown actors (in ``<actor name>``, successors, ``timeoutBranch`` and
platform lines), unknown plugins, plugins on a bus their class does not declare, params read
as the plugin will read them (each value by its ``Param``, the class's cross-param rules,
``area`` names against the world's areas when it is given, a transition's params by the
successors' plugins that take them), duplicate transitions for one event, branch counts
against ``sysNum``, a platform starting one actor twice, one ``barrierKey`` on different
events (a warning). These run even when the builder found errors, on whatever it could
build, so one pass reports as much as possible.

:func:`check_whole` — rules about the script as a whole: actors no platform can ever run
(a warning), barrier groups that can never fire and ``sysNum`` values more than the branch
counts can ever send (:mod:`actorswarm.dsl.feasibility`), and events a ``core.emit_after``
emits that no transition handles (a warning). They reason about everything at once, so they
only run on a script with no error left: a missing piece would make their conclusions
wrong.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.feasibility import edges, infeasible_groups, reachable
from actorswarm.dsl.model import Param, PluginSpec, Position, TaskScript, Transition
from actorswarm.dsl.plugins import param_rules, plugin_class
from actorswarm.dsl.syntax import id_ranges, plugin_kind
from actorswarm.suggest import did_you_mean

if TYPE_CHECKING:
    from actorswarm.runtime.plugin import Plugin

_LOST = "_lost"


def _listing(names: Iterable[str], limit: int = 8) -> str:
    ordered = sorted(set(names))
    shown = ", ".join(ordered[:limit])
    return shown + (f" and {len(ordered) - limit} more" if len(ordered) > limit else "")


def check_references(
    script: TaskScript,
    report: Report,
    known_plugins: Collection[str],
    *,
    all_actors_built: bool = True,
    areas: Collection[str] | None = None,
) -> None:
    """Rules about single nodes and what they name (see the module docstring).

    With ``all_actors_built`` False (an ``<Actor>`` was too broken to build), references to
    undefined actors are not reported: the broken actor may be the one they name. ``areas``
    are the names of the world's areas, against which every ``area`` param is looked up
    (None: the world is not known here, names are not checked).
    """
    params = _ParamCheck(report, areas)
    _check_actors(script, report, known_plugins, params)
    names = _Names(tuple(actor.name for actor in script.actors), complete=all_actors_built)
    for transitions in script.transitions.values():
        _check_transitions(transitions, names, report)
        for transition in transitions:
            _check_transition_params(script, transition, known_plugins, params)
    _check_platforms(script, names, report)
    _check_keys(script, report)


@dataclass(frozen=True, slots=True)
class _Names:
    """The defined actor names, and whether a name missing from them is surely undefined."""

    defined: tuple[str, ...]
    complete: bool

    def undefined(self, name: str) -> bool:
        return self.complete and name not in self.defined

    def hint(self, name: str) -> str:
        """A suggestion for the undefined ``name`` and the list of defined actors."""
        return f"{did_you_mean(name, self.defined)} (actors: {_listing(self.defined)})"


def _check_actors(
    script: TaskScript, report: Report, known_plugins: Collection[str], params: _ParamCheck
) -> None:
    named: dict[str, Position] = {}
    numbered: dict[int, tuple[str, Position]] = {}
    for actor in script.actors:
        name_pos = actor.attr_pos.get("_P_Name", actor.pos)
        if actor.name in named:
            report.error(
                name_pos,
                f"actor {actor.name} is already defined at {named[actor.name]}; "
                "give each actor a unique name",
            )
        named.setdefault(actor.name, name_pos)
        if "_P_ID" in actor.attr_pos:  # assigned IDs never collide; written ones may
            id_pos = actor.attr_pos["_P_ID"]
            if actor.id in numbered:
                other, other_pos = numbered[actor.id]
                report.error(
                    id_pos,
                    f"actor ID {actor.id} is already used by actor {other} at {other_pos}; "
                    "give each actor its own _P_ID, or leave _P_ID out to number them in order",
                )
            numbered.setdefault(actor.id, (actor.name, id_pos))
        for bus, plugin in actor.plugins():
            if plugin_kind(plugin.name) == "path":
                # A module:Class path is resolved when the actor starts: importing it here
                # would run code named by the script on the checking machine.
                continue
            if plugin.name not in known_plugins:
                report.error(
                    plugin.pos,
                    f"plugin {plugin.name!r} is not installed"
                    f"{did_you_mean(plugin.name, known_plugins)}; install the package that "
                    f"provides it or fix the name (installed: {_listing(known_plugins)})",
                )
            else:
                cls = plugin_class(plugin.name)
                if cls is not None:
                    _check_bus(bus, plugin, cls, report)
                rules = param_rules(plugin.name)
                if rules is not None:
                    params.plugin(plugin, rules, cls)


def _check_bus(bus: str, plugin: PluginSpec, cls: type[Plugin], report: Report) -> None:
    """A plugin on a bus its class does not declare (an error): the buses run in OODA order,
    so a detector on ``act_bus`` would feed the act plugins a step late. A plugin that fits
    anywhere declares ``any_bus``."""
    if cls.any_bus or cls.bus == bus:
        return
    report.error(
        plugin.pos,
        f"{plugin.name} is written for {cls.bus} (its class declares bus = {cls.bus!r}), not "
        f"{bus}; move this <Plugin> into the <Bus> of {cls.bus}",
    )


@dataclass(frozen=True, slots=True)
class _ParamCheck:
    """Reads params the way the plugins will: each value by its :class:`Param`, the rules
    that tie params together by the class's ``check_params``, ``area`` names against the
    world's ``areas`` when they are known."""

    report: Report
    areas: Collection[str] | None

    def plugin(
        self, plugin: PluginSpec, rules: Mapping[str, Any], cls: type[Plugin] | None
    ) -> None:
        """Every param of one ``<Plugin>``, then its cross-param rules."""
        name, report = plugin.name, self.report
        given = {param.key: param for param in plugin.params}
        values: dict[str, object] = {}
        for param in plugin.params:
            if param.key not in rules:
                accepted = f"it takes {', '.join(rules)}" if rules else "it takes no params"
                report.error(
                    param.pos,
                    f"{name} has no param {param.key!r}{did_you_mean(param.key, rules)}; "
                    f"{accepted}",
                )
                continue
            read = self.value(name, rules[param.key], param)
            if read is not None:
                values[param.key] = read
        missing = [key for key, rule in rules.items() if rule.required and key not in given]
        for key in missing:
            report.error(
                plugin.pos,
                f"{name} needs the param {key} ({rules[key].meaning}): add "
                f'<param key="{key}" value="..."/> to its <Plugin>',
            )
        if cls is None or missing or len(values) < len(given):
            return  # the rules that tie params together need every one of them read
        for key, declared in cls.params.items():
            values.setdefault(key, declared.default)
        try:
            problems = list(cls.check_params(values))
        except ValueError as exc:
            problems = [("", str(exc))]
        except Exception as exc:  # the plugin's own code: a bug there must not end the check
            problems = [("", f"its check_params failed ({type(exc).__name__}: {exc})")]
        for key, message in problems:
            where = given[key].pos if key in given else plugin.pos
            report.error(where, f"{name}: {message}")

    def value(self, plugin: str, rule: Any, param: Param, into: str = "") -> object | None:
        """``param`` read by ``rule`` (None, and an error at the param, when it does not
        read); ``into`` names the actor a transition's param goes to."""
        try:
            value: object = rule.parse(param.value)
        except ValueError as exc:
            self.report.error(param.pos, f"{plugin}{into}: {exc}")
            return None
        if getattr(rule, "kind", None) == "area" and self.areas is not None:
            from actorswarm.runtime.shapes import area_name  # with the plugins, when needed

            name = area_name(param.value)
            if name is not None and name not in self.areas:
                known = f"its areas are {_listing(self.areas)}" if self.areas else "it has none"
                self.report.error(
                    param.pos,
                    f"{plugin}{into}: the world has no area {name!r}"
                    f"{did_you_mean(name, self.areas)}; {known} (name one of them, or give a "
                    'rectangle "x_min y_min x_max y_max")',
                )
                return None
        return value


def _check_transition_params(
    script: TaskScript, transition: Transition, known_plugins: Collection[str], check: _ParamCheck
) -> None:
    """A transition's params go to every plugin of its successors that declares the key
    (laid over the script's own), so each is read as those plugins will read it. A key no
    plugin declares is data for the successor and is left alone."""
    if not transition.params:
        return
    targets: list[tuple[str, str, Mapping[str, Any]]] = []
    for successor in transition.successors:
        try:
            actor = script.actor(successor)
        except KeyError:
            continue  # reported as an undefined successor
        for _, spec in actor.plugins():
            rules = param_rules(spec.name) if spec.name in known_plugins else None
            if rules is not None:
                targets.append((successor, spec.name, rules))
    for param in transition.params:
        for successor, plugin, rules in targets:
            if param.key in rules:
                check.value(plugin, rules[param.key], param, f" (in {successor})")


def _check_transitions(transitions: tuple[Transition, ...], names: _Names, report: Report) -> None:
    first = transitions[0]
    if names.undefined(first.actor):
        report.error(
            first.at("actor"),
            f"transitions are given for actor {first.actor}, which is not defined"
            f"{names.hint(first.actor)}; define it in <_ActorsConfig>",
        )
    events: dict[str, Position] = {}
    for transition in transitions:
        if transition.event in events:
            report.error(
                transition.at("name"),
                f"actor {transition.actor} already has a transition for {transition.event} at "
                f"{events[transition.event]}; one event triggers one transition per actor "
                "(use <branch> elements to send participants to several actors)",
            )
        events.setdefault(transition.event, transition.at("name"))
        for branch in transition.branches:
            if names.undefined(branch.successor):
                report.error(
                    branch.successor_pos,
                    f"the successor {branch.successor} is not a defined actor"
                    f"{names.hint(branch.successor)}",
                )
        if transition.timeout_branch is not None:
            if names.undefined(transition.timeout_branch):
                report.error(
                    transition.at("timeoutBranch"),
                    f"timeoutBranch {transition.timeout_branch} is not a defined actor"
                    f"{names.hint(transition.timeout_branch)}",
                )
            if transition.timeout is None:
                report.warning(
                    transition.at("timeoutBranch"),
                    'timeoutBranch has no effect without a timeout; add timeout="SECONDS" '
                    "or remove timeoutBranch",
                )
        _check_counts(transition, report)
        lost = transition.event.removesuffix(_LOST)
        if transition.event.endswith(_LOST) and lost not in names.defined:
            hint = did_you_mean(lost, names.defined)
            if hint:
                report.warning(
                    transition.at("name"),
                    f"{transition.event} is not the built-in event of a lost actor: there is no "
                    f"actor {lost}{hint}",
                )


def _check_counts(transition: Transition, report: Report) -> None:
    """Branch counts against sysNum (docs/design.md §4, and docs/task-scripts.md for "all")."""
    rests = [b for b in transition.branches if b.count == "rest"]
    fixed = sum(b.count for b in transition.branches if b.count != "rest")
    for extra in rests[1:]:
        report.error(
            extra.pos,
            'a transition has at most one cnt="rest" branch; give this one an integer count',
        )
    sys_num = transition.sys_num
    where = transition.at("sysNum")
    if sys_num == "all":
        if not rests:
            report.error(
                where,
                'with sysNum="all" the number of participants is known only when the event '
                'comes, so integer counts cannot add up to it; mark one branch cnt="rest" to '
                "take the remainder",
            )
        return
    if fixed > sys_num:
        report.error(
            where,
            f"the branch counts add up to {fixed}, more than sysNum {sys_num}; lower the "
            "counts or raise sysNum",
        )
    elif not rests and fixed != sys_num:
        report.error(
            where,
            f"the branch counts add up to {fixed} but sysNum is {sys_num}; make them add up "
            f'to {sys_num}, or mark one branch cnt="rest" to take the remainder',
        )
    elif rests and fixed == sys_num and len(transition.branches) > 1:
        report.warning(
            rests[0].pos,
            f"the integer counts already add up to sysNum {sys_num}, so this "
            'cnt="rest" branch never gets a participant',
        )


def _check_keys(script: TaskScript, report: Report) -> None:
    """A ``barrierKey`` shared by transitions on different events (a warning): the group
    fires only when every part has its candidates, so the platforms that got one event
    wait for the other one, which a script may mean (a rendezvous) but mostly does not."""
    first: dict[int, Transition] = {}
    for transition in script.all_transitions():
        key = transition.barrier_key
        if key is None:
            continue
        other = first.setdefault(key, transition)
        if other.event != transition.event:
            report.warning(
                transition.at("barrierKey"),
                f"barrierKey {key} joins {transition.event} of {transition.actor} to "
                f"{other.event} of {other.actor} at {other.at('name')}: the group fires only "
                f"when both events have come, so the holders of {transition.actor} that got "
                f"{transition.event} wait for {other.event} (and the others the other way "
                f"round){_until(transition, other)}; give them different barrier keys unless "
                "they are meant to wait for each other",
            )


def _until(*transitions: Transition) -> str:
    if any(t.timeout is not None for t in transitions):
        return ", until it comes or the group's timeout expires"
    return ", for ever if it never comes (no timeout)"


def _platforms(ids: frozenset[int]) -> str:
    """``'platform 7 starts'`` or ``'platforms 1-3 start'``."""
    if len(ids) == 1:
        return f"platform {id_ranges(ids)} starts"
    return f"platforms {id_ranges(ids)} start"


def _check_platforms(script: TaskScript, names: _Names, report: Report) -> None:
    started: dict[str, dict[int, Position]] = {}
    for line in script.platforms:
        if names.undefined(line.actor):
            report.error(
                line.at("actor"),
                f"{_platforms(line.ids)} actor {line.actor}, which is not "
                f"defined{names.hint(line.actor)}",
            )
        already = started.setdefault(line.actor, {})
        twice = sorted(already.keys() & line.ids)
        if twice:
            report.error(
                line.at("id"),
                f"platform {twice[0]} already starts actor {line.actor} at "
                f"{already[twice[0]]}; a platform runs an actor once, so remove "
                f"{id_ranges(frozenset(twice))} from one of the lines",
            )
        for platform in line.ids - already.keys():
            already[platform] = line.at("id")


def check_whole(script: TaskScript, report: Report) -> None:
    """Rules about the whole script; call only when no error was found before."""
    everywhere = reachable(edges(script), script.initial_actors())
    for actor in script.actors:
        if actor.name not in everywhere:
            report.warning(
                actor.pos,
                f"no platform ever runs actor {actor.name}: no <platform> line starts it and "
                "no transition from a started actor leads to it; start it, add a transition "
                "to it, or delete it",
            )
    for found in infeasible_groups(script):
        say = report.warning if found.warning else report.error
        say(found.where or found.group.members[0].pos, found.message)
    handled = {t.event for t in script.all_transitions()}
    for actor in script.actors:
        for _, plugin in actor.plugins():
            if plugin.name != "core.emit_after":
                continue
            for param in plugin.params:
                if param.key == "event" and param.value.strip() not in handled:
                    event = param.value.strip()
                    report.warning(
                        param.pos,
                        f"core.emit_after emits {event}, but no transition handles it"
                        f"{did_you_mean(event, handled)}; the event will be ignored",
                    )
