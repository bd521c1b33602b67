"""From the positioned XML tree to the model: structure and value syntax.

:data:`GRAMMAR` is the whole shape of the format in one table — for every element, the
attributes it must and may have, the children it may hold (with how many) and whether it
holds text. :func:`build` walks the tree against that table, then reads each value with
:mod:`actorswarm.dsl.syntax`, and reports every problem it meets to a
:class:`~actorswarm.dsl.diagnostics.Report` instead of stopping at the first.

What it cannot build it leaves out, chosen so that leaving it out causes no second,
misleading message: an actor whose name is valid is always kept (with its ID or priority
defaulted when those are wrong), because transitions and platform lines refer to it by
name; a broken transition, plugin or platform line is dropped, since nothing refers to it.
The model it returns is therefore only trusted by the checker when no error was reported.

Actor IDs that are not written (``_P_ID`` is optional) are assigned in script order, each the
smallest positive ID no ``_P_ID`` in the script and no earlier actor uses, so written and
assigned IDs never collide, and a script without any ``_P_ID`` numbers its actors 1, 2, 3...
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TypeVar

from actorswarm.dsl import syntax
from actorswarm.dsl.diagnostics import Report
from actorswarm.dsl.model import (
    BUSES,
    Actor,
    Branch,
    BusName,
    Param,
    PlatformLine,
    PluginSpec,
    Position,
    TaskScript,
    Transition,
    frozen_map,
)
from actorswarm.dsl.parser import XmlElement
from actorswarm.suggest import did_you_mean

_T = TypeVar("_T")

#: How many (platform, actor) starts all ``<platform>`` lines may add up to: every platform
#: of a full 65535-ID swarm starting 16 actors. It keeps a short script from making the
#: checker build hundreds of millions of entries.
MAX_PLATFORM_STARTS = 16 * syntax.MAX_PLATFORM_ID


@dataclass(frozen=True, slots=True)
class Shape:
    """What one element may contain: ``required``/``optional`` attributes, ``children``
    (tag -> (least, most), ``None`` for no limit) and whether it holds ``text``."""

    required: tuple[str, ...] = ()
    optional: tuple[str, ...] = ()
    children: Mapping[str, tuple[int, int | None]] = field(default_factory=dict)
    text: bool = False


_TEXT = Shape(text=True)

#: The format, element by element (docs/design.md §4). The XSD in ``schema.xsd`` mirrors it.
GRAMMAR: Mapping[str, Shape] = {
    "TaskScript": Shape(
        required=("name",),
        optional=("version",),
        children={"_ActorsConfig": (1, 1), "_TaskConfig": (0, 1), "_PlatformActorConfig": (1, 1)},
    ),
    "_ActorsConfig": Shape(children={"Actor": (1, None)}),
    "Actor": Shape(
        children={"_P_Name": (1, 1), "_P_ID": (0, 1), "_P_Prio": (0, 1), "OODAConfig": (0, 1)}
    ),
    "_P_Name": _TEXT,
    "_P_ID": _TEXT,
    "_P_Prio": _TEXT,
    "OODAConfig": Shape(children={"Bus": (0, None)}),
    "Bus": Shape(children={"_P_Name": (1, 1), "Plugin": (0, None)}),
    "Plugin": Shape(children={"_P_Name": (1, None), "param": (0, None)}),
    "param": Shape(required=("key", "value")),
    "_TaskConfig": Shape(children={"actor": (0, None)}),
    "actor": Shape(required=("name",), children={"transition": (0, None)}),
    "transition": Shape(
        required=("name", "sysNum"),
        optional=("barrierKey", "timeout", "timeoutBranch"),
        children={"param": (0, None), "successor": (0, 1), "branch": (0, None)},
    ),
    "branch": Shape(required=("cnt",), children={"successor": (1, 1)}),
    "successor": Shape(required=("actor",)),
    "_PlatformActorConfig": Shape(children={"platform": (1, None)}),
    "platform": Shape(required=("id", "actor")),
}

# Examples that turn "X is missing" into "write this".
_ATTRIBUTE_EXAMPLES = {
    ("TaskScript", "name"): 'name="search-and-track"',
    ("param", "key"): 'key="spacing"',
    ("param", "value"): 'value="20"',
    ("actor", "name"): 'name="A" (the actor these transitions leave)',
    ("transition", "name"): 'name="finish_event" (the event that triggers it)',
    ("transition", "sysNum"): 'sysNum="10" (how many platforms switch) or sysNum="all"',
    ("branch", "cnt"): 'cnt="2" or cnt="rest"',
    ("successor", "actor"): 'actor="B"',
    ("platform", "id"): 'id="1-10"',
    ("platform", "actor"): 'actor="A"',
}
_CHILD_EXAMPLES = {
    "_ActorsConfig": "<_ActorsConfig> with one <Actor> per actor",
    "_PlatformActorConfig": '<_PlatformActorConfig><platform id="1-10" actor="A"/>'
    "</_PlatformActorConfig>",
    "Actor": "<Actor><_P_Name>A</_P_Name>...</Actor>",
    "_P_Name": "<_P_Name>Search</_P_Name>",
    "platform": '<platform id="1-10" actor="A"/>',
    "successor": '<successor actor="B"/>',
}
# Attributes editors add to the root to find the schema; they mean nothing to the format.
_ROOT_EXTRA_PREFIXES = ("xmlns:", "xsi:")


def _parents_of(tag: str) -> list[str]:
    return [parent for parent, shape in GRAMMAR.items() if tag in shape.children]


def _fits(element: XmlElement, report: Report) -> bool:
    """Check ``element`` against :data:`GRAMMAR`; report every misfit. False when a
    required attribute or child is missing (the element cannot be built)."""
    shape = GRAMMAR[element.tag]
    complete = True
    allowed = shape.required + shape.optional
    for attribute in element.attributes:
        if attribute.name in allowed:
            continue
        if element.tag == "TaskScript" and attribute.name.startswith(_ROOT_EXTRA_PREFIXES):
            continue
        where = f"allowed: {', '.join(allowed)}" if allowed else "it takes none"
        report.error(
            attribute.pos,
            f'<{element.tag}> has no attribute "{attribute.name}"'
            f"{did_you_mean(attribute.name, allowed)}; {where}",
        )
    for name in shape.required:
        if element.attribute(name) is None:
            example = _ATTRIBUTE_EXAMPLES.get((element.tag, name), f'{name}="..."')
            report.error(element.pos, f"<{element.tag}> needs a {name} attribute: add {example}")
            complete = False
    seen: Counter[str] = Counter()
    for child in element.children:
        if child.tag not in shape.children:
            _misplaced(element, child, report)
            continue
        seen[child.tag] += 1
        most = shape.children[child.tag][1]
        if most is not None and seen[child.tag] > most:
            report.error(
                child.pos,
                f"<{element.tag}> takes {'one' if most == 1 else f'at most {most}'} "
                f"<{child.tag}>; remove this one or merge it into the first",
            )
    for tag, (least, _) in shape.children.items():
        if seen[tag] < least:
            example = _CHILD_EXAMPLES.get(tag, f"<{tag}>")
            report.error(element.pos, f"<{element.tag}> needs a <{tag}>: add {example}")
            complete = False
    if element.text_pos is not None and not shape.text:
        snippet = " ".join(element.text.split())
        snippet = snippet if len(snippet) <= 30 else snippet[:27] + "..."
        report.error(
            element.text_pos,
            f"text {snippet!r} is not allowed inside <{element.tag}>; "
            "only elements go here (use <!-- ... --> for a comment)",
        )
    return complete


def _misplaced(parent: XmlElement, child: XmlElement, report: Report) -> None:
    allowed = list(GRAMMAR[parent.tag].children)
    if not allowed:
        report.error(child.pos, f"<{parent.tag}> holds only text, not a <{child.tag}> element")
        return
    homes = _parents_of(child.tag)
    if homes:
        places = " or ".join(f"<{home}>" for home in homes)
        report.error(
            child.pos, f"<{child.tag}> does not belong inside <{parent.tag}>; it goes in {places}"
        )
        return
    listing = ", ".join(f"<{tag}>" for tag in allowed)
    report.error(
        child.pos,
        f"unknown element <{child.tag}> inside <{parent.tag}>"
        f"{did_you_mean(child.tag, allowed)}; allowed here: {listing}",
    )


def _children(element: XmlElement | None, tag: str) -> list[XmlElement]:
    return [] if element is None else [c for c in element.children if c.tag == tag]


def _first(element: XmlElement | None, tag: str) -> XmlElement | None:
    found = _children(element, tag)
    return found[0] if found else None


def _text_pos(element: XmlElement) -> Position:
    return element.text_pos or element.pos


def _read(report: Report, pos: Position, parse: Callable[[str], _T], text: str) -> _T | None:
    """``parse(text)``, or None after reporting its ``ValueError`` at ``pos``."""
    try:
        return parse(text)
    except ValueError as exc:
        report.error(pos, str(exc))
        return None


@dataclass(frozen=True, slots=True)
class Built:
    """What :func:`build` made: the ``script``, and whether every ``<Actor>`` could be built
    (when one could not, its name may be the one other parts refer to, so "unknown actor"
    would only repeat the real error)."""

    script: TaskScript
    all_actors_built: bool


class _Builder:
    def __init__(self, report: Report) -> None:
        self.report = report
        self.platform_starts = 0
        self.all_actors_built = True

    # <_ActorsConfig>

    def actors(self, section: XmlElement | None) -> tuple[Actor, ...]:
        elements = _children(section, "Actor")
        drafts = [d for el in elements if (d := self.actor(el)) is not None]
        self.all_actors_built = len(drafts) == len(elements)
        taken = {d.id for d in drafts if d.id is not None}
        next_id = 1
        actors: list[Actor] = []
        for draft in drafts:
            actor_id = draft.id
            if actor_id is None:
                while next_id in taken:
                    next_id += 1
                actor_id = next_id
                taken.add(actor_id)
            actors.append(
                Actor(
                    name=draft.name,
                    id=actor_id,
                    priority=draft.priority,
                    buses=frozen_map(draft.buses),
                    pos=draft.pos,
                    attr_pos=frozen_map(draft.attr_pos),
                )
            )
        return tuple(actors)

    def actor(self, element: XmlElement) -> _ActorDraft | None:
        if not _fits(element, self.report):
            return None
        name_el = _first(element, "_P_Name")
        assert name_el is not None  # _fits checked it
        _fits(name_el, self.report)
        name = _read(
            self.report,
            _text_pos(name_el),
            lambda text: syntax.name(text, what="actor name"),
            name_el.text,
        )
        if name is None:
            return None
        draft = _ActorDraft(name=name, pos=element.pos, attr_pos={"_P_Name": _text_pos(name_el)})
        if (id_el := _first(element, "_P_ID")) is not None and _fits(id_el, self.report):
            draft.id = _read(
                self.report,
                _text_pos(id_el),
                lambda text: syntax.integer(
                    text,
                    what="_P_ID (the actor ID)",
                    low=syntax.MIN_ACTOR_ID,
                    high=syntax.MAX_ACTOR_ID,
                ),
                id_el.text,
            )
            if draft.id is not None:  # only written, valid IDs are checked for duplicates
                draft.attr_pos["_P_ID"] = _text_pos(id_el)
        if (prio_el := _first(element, "_P_Prio")) is not None and _fits(prio_el, self.report):
            priority = _read(
                self.report,
                _text_pos(prio_el),
                lambda text: syntax.integer(
                    text,
                    what="_P_Prio (the priority, larger wins)",
                    low=syntax.MIN_PRIORITY,
                    high=syntax.MAX_PRIORITY,
                ),
                prio_el.text,
            )
            draft.priority = 0 if priority is None else priority
        ooda = _first(element, "OODAConfig")
        if ooda is not None and _fits(ooda, self.report):
            self.buses(ooda, draft)
        return draft

    def buses(self, ooda: XmlElement, draft: _ActorDraft) -> None:
        where: dict[str, Position] = {}
        for bus_el in _children(ooda, "Bus"):
            if not _fits(bus_el, self.report):
                continue
            name_el = _first(bus_el, "_P_Name")
            assert name_el is not None
            _fits(name_el, self.report)
            bus = name_el.text.strip()
            pos = _text_pos(name_el)
            bus_name = _BUS_NAMES.get(bus)
            if bus_name is None:
                self.report.error(
                    pos,
                    f"unknown bus {bus!r}{did_you_mean(bus, BUSES)}; "
                    f"a bus is one of {', '.join(BUSES)}",
                )
                continue
            if bus in where:
                self.report.error(
                    pos,
                    f"actor {draft.name} already configures {bus} at {where[bus]}; "
                    "list all of that bus's plugins in one <Bus>",
                )
                continue
            where[bus] = pos
            plugins: list[PluginSpec] = []
            for plugin_el in _children(bus_el, "Plugin"):
                plugins.extend(self.plugin(plugin_el))
            draft.buses[bus_name] = tuple(plugins)

    def plugin(self, element: XmlElement) -> list[PluginSpec]:
        if not _fits(element, self.report):
            return []
        names = _children(element, "_P_Name")
        param_els = _children(element, "param")
        if len(names) > 1 and param_els:
            self.report.error(
                param_els[0].pos,
                f"this <Plugin> lists {len(names)} plugins, so its params would be ambiguous; "
                "give each plugin that takes params its own <Plugin>",
            )
            return []
        params = self.params(param_els, owner="plugin")
        specs: list[PluginSpec] = []
        for name_el in names:
            _fits(name_el, self.report)
            pos = _text_pos(name_el)
            if _read(self.report, pos, syntax.plugin_kind, name_el.text) is not None:
                specs.append(PluginSpec(name=name_el.text.strip(), params=params, pos=pos))
        return specs

    def params(self, elements: Iterable[XmlElement], *, owner: str) -> tuple[Param, ...]:
        params: list[Param] = []
        where: dict[str, Position] = {}
        for element in elements:
            if not _fits(element, self.report):
                continue
            key_attr = element.attribute("key")
            value_attr = element.attribute("value")
            assert key_attr is not None and value_attr is not None
            key = key_attr.value.strip()
            if not key:
                self.report.error(key_attr.pos, f"a {owner} param needs a non-empty key")
                continue
            if key in where:
                self.report.error(
                    key_attr.pos,
                    f"param {key!r} is already set at {where[key]}; keep one of the two",
                )
                continue
            where[key] = key_attr.pos
            params.append(Param(key=key, value=value_attr.value, pos=element.pos))
        return tuple(params)

    # <_TaskConfig>

    def transitions(self, section: XmlElement | None) -> dict[str, tuple[Transition, ...]]:
        by_actor: dict[str, list[Transition]] = {}
        blocks: dict[str, Position] = {}
        for block in _children(section, "actor"):
            if not _fits(block, self.report):
                continue
            name_attr = block.attribute("name")
            assert name_attr is not None
            name = _read(
                self.report,
                name_attr.pos,
                lambda text: syntax.name(text, what="actor name"),
                name_attr.value,
            )
            if name is None:
                continue
            if name in blocks:
                self.report.error(
                    block.pos,
                    f"actor {name} already has an <actor> block at {blocks[name]}; "
                    "put all of its transitions in that one",
                )
            blocks.setdefault(name, name_attr.pos)
            found = by_actor.setdefault(name, [])
            for element in _children(block, "transition"):
                transition = self.transition(element, name, name_attr.pos)
                if transition is not None:
                    found.append(transition)
        return {name: tuple(found) for name, found in by_actor.items() if found}

    def transition(self, element: XmlElement, actor: str, actor_pos: Position) -> Transition | None:
        complete = _fits(element, self.report)
        attrs = _Attributes(element, self.report)
        event = attrs.read("name", lambda text: syntax.name(text, what="event name"))
        sys_num = attrs.read("sysNum", syntax.sys_num)
        barrier_key = attrs.read("barrierKey", syntax.barrier_key)
        timeout = attrs.read("timeout", syntax.timeout)
        timeout_branch = attrs.read(
            "timeoutBranch", lambda text: syntax.name(text, what="timeoutBranch actor name")
        )
        params = self.params(_children(element, "param"), owner="transition")
        branches = self.branches(element)
        if not complete or attrs.failed or event is None or sys_num is None or branches is None:
            return None
        return Transition(
            actor=actor,
            event=event,
            sys_num=sys_num,
            branches=branches,
            barrier_key=barrier_key,
            timeout=timeout,
            timeout_branch=timeout_branch,
            params=params,
            pos=element.pos,
            attr_pos=frozen_map({"actor": actor_pos} | {a.name: a.pos for a in element.attributes}),
        )

    def branches(self, element: XmlElement) -> tuple[Branch, ...] | None:
        successors = _children(element, "successor")
        branch_els = _children(element, "branch")
        if successors and branch_els:
            self.report.error(
                branch_els[0].pos,
                "a <transition> has either one <successor> (every participant goes there) "
                "or <branch> elements, not both; move the <successor> into a <branch>",
            )
            return None
        if not successors and not branch_els:
            self.report.error(
                element.pos,
                '<transition> needs a successor: add <successor actor="B"/>, or '
                '<branch cnt="2"><successor actor="B"/></branch> elements to split',
            )
            return None
        if successors:
            successor = self.successor(successors[0])
            if successor is None:
                return None
            name, pos = successor
            return (Branch(count="rest", successor=name, pos=successors[0].pos, successor_pos=pos),)
        branches: list[Branch] = []
        for branch_el in branch_els:
            if not _fits(branch_el, self.report):
                continue
            cnt = branch_el.attribute("cnt")
            assert cnt is not None
            count = _read(self.report, cnt.pos, syntax.count, cnt.value)
            successor_el = _first(branch_el, "successor")
            assert successor_el is not None
            successor = self.successor(successor_el)
            if count is not None and successor is not None:
                name, pos = successor
                branches.append(
                    Branch(count=count, successor=name, pos=branch_el.pos, successor_pos=pos)
                )
        return tuple(branches) if len(branches) == len(branch_els) else None

    def successor(self, element: XmlElement) -> tuple[str, Position] | None:
        if not _fits(element, self.report):
            return None
        attr = element.attribute("actor")
        assert attr is not None
        name = _read(
            self.report,
            attr.pos,
            lambda text: syntax.name(text, what="successor actor name"),
            attr.value,
        )
        return None if name is None else (name, attr.pos)

    # <_PlatformActorConfig>

    def platforms(self, section: XmlElement | None) -> tuple[PlatformLine, ...]:
        lines: list[PlatformLine] = []
        for element in _children(section, "platform"):
            if not _fits(element, self.report):
                continue
            id_attr = element.attribute("id")
            actor_attr = element.attribute("actor")
            assert id_attr is not None and actor_attr is not None
            ids = _read(self.report, id_attr.pos, syntax.platform_ids, id_attr.value)
            actor = _read(
                self.report,
                actor_attr.pos,
                lambda text: syntax.name(text, what="actor name"),
                actor_attr.value,
            )
            if ids is None or actor is None:
                continue
            self.platform_starts += len(ids)
            if self.platform_starts > MAX_PLATFORM_STARTS:
                self.report.error(
                    id_attr.pos,
                    f"the platform lines start more than {MAX_PLATFORM_STARTS} actors in all; "
                    "a swarm has at most 65535 platforms",
                )
                break
            lines.append(
                PlatformLine(
                    ids=ids,
                    actor=actor,
                    pos=element.pos,
                    attr_pos=frozen_map({a.name: a.pos for a in element.attributes}),
                )
            )
        return tuple(lines)


@dataclass(slots=True)
class _ActorDraft:
    name: str
    pos: Position
    attr_pos: dict[str, Position]
    id: int | None = None
    priority: int = 0
    buses: dict[BusName, tuple[PluginSpec, ...]] = field(default_factory=dict)


class _Attributes:
    """Reads an element's optional attributes, remembering whether any was invalid."""

    def __init__(self, element: XmlElement, report: Report) -> None:
        self.element = element
        self.report = report
        self.failed = False

    def read(self, name: str, parse: Callable[[str], _T]) -> _T | None:
        """The parsed attribute, or None when it is absent or invalid (then reported)."""
        attr = self.element.attribute(name)
        if attr is None:
            return None
        value = _read(self.report, attr.pos, parse, attr.value)
        self.failed = self.failed or value is None
        return value


_BUS_NAMES: Mapping[str, BusName] = {bus: bus for bus in BUSES}


def build(root: XmlElement, report: Report, *, path: str | None = None) -> Built | None:
    """Build the model of the script whose root element is ``root``.

    Every structural and value problem goes to ``report``. Returns None only when the root
    is not a ``<TaskScript>``; otherwise the model of everything that could be built (see
    the module docstring for what is left out).
    """
    if root.tag != "TaskScript":
        report.error(
            root.pos,
            f"the root element must be <TaskScript>, not <{root.tag}>"
            f"{did_you_mean(root.tag, ['TaskScript'])}",
        )
        return None
    _fits(root, report)
    builder = _Builder(report)
    sections = {tag: _first(root, tag) for tag in GRAMMAR["TaskScript"].children}
    for section in sections.values():
        if section is not None:
            _fits(section, report)
    name_attr = root.attribute("name")
    if name_attr is not None and not name_attr.value.strip():
        report.error(name_attr.pos, 'the script name is empty: write name="search-and-track"')
    version_attr = root.attribute("version")
    script = TaskScript(
        name=name_attr.value.strip() if name_attr is not None else "",
        version=version_attr.value.strip() if version_attr is not None else "1",
        actors=builder.actors(sections["_ActorsConfig"]),
        transitions=frozen_map(builder.transitions(sections["_TaskConfig"])),
        platforms=builder.platforms(sections["_PlatformActorConfig"]),
        path=path,
        pos=root.pos,
    )
    return Built(script, builder.all_actors_built)
