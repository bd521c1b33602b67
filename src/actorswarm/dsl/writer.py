"""Write a model back as a task script, in the canonical form of docs/design.md §4.

Reading what :func:`to_xml` writes gives back an equal model (positions aside), which is how
the tests pin down that the builder loses nothing. The canonical form writes every actor's
ID and priority, one ``<Plugin>`` per plugin, a bare ``<successor>`` for a transition with
one all-taking branch, and platform IDs as the shortest list of ranges.
"""

from __future__ import annotations

from xml.sax.saxutils import escape

from actorswarm.dsl.model import Actor, Param, PlatformLine, TaskScript, Transition
from actorswarm.dsl.syntax import id_ranges

# Attribute values lose newlines and tabs to XML's attribute normalization unless written
# as character references.
_ATTRIBUTE_ESCAPES = {'"': "&quot;", "\n": "&#10;", "\r": "&#13;", "\t": "&#9;"}


def _attr(value: str) -> str:
    return '"' + escape(value, _ATTRIBUTE_ESCAPES) + '"'


def number(value: float) -> str:
    """``60.0`` -> ``'60'``, ``0.5`` -> ``'0.5'``: the shortest text that reads back equal."""
    return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)


def _params(params: tuple[Param, ...], indent: str) -> list[str]:
    return [f"{indent}<param key={_attr(p.key)} value={_attr(p.value)}/>" for p in params]


def _actor(actor: Actor) -> list[str]:
    lines = [
        "    <Actor>",
        f"      <_P_Name>{escape(actor.name)}</_P_Name>",
        f"      <_P_ID>{actor.id}</_P_ID>",
        f"      <_P_Prio>{actor.priority}</_P_Prio>",
    ]
    if actor.buses:
        lines.append("      <OODAConfig>")
        for bus, plugins in actor.buses.items():
            lines += ["        <Bus>", f"          <_P_Name>{bus}</_P_Name>"]
            for plugin in plugins:
                name = f"<_P_Name>{escape(plugin.name)}</_P_Name>"
                if not plugin.params:
                    lines.append(f"          <Plugin>{name}</Plugin>")
                    continue
                lines += ["          <Plugin>", f"            {name}"]
                lines += _params(plugin.params, "            ")
                lines.append("          </Plugin>")
            lines.append("        </Bus>")
        lines.append("      </OODAConfig>")
    lines.append("    </Actor>")
    return lines


def _transition(transition: Transition) -> list[str]:
    attrs = [f"name={_attr(transition.event)}"]
    if transition.barrier_key is not None:
        attrs.append(f'barrierKey="{transition.barrier_key}"')
    attrs.append(f'sysNum="{transition.sys_num}"')
    if transition.timeout is not None:
        attrs.append(f'timeout="{number(transition.timeout)}"')
    if transition.timeout_branch is not None:
        attrs.append(f"timeoutBranch={_attr(transition.timeout_branch)}")
    lines = [f"      <transition {' '.join(attrs)}>"]
    lines += _params(transition.params, "        ")
    only = transition.branches[0] if len(transition.branches) == 1 else None
    if only is not None and only.count == "rest":
        lines.append(f"        <successor actor={_attr(only.successor)}/>")
    else:
        lines += [
            f'        <branch cnt="{b.count}"><successor actor={_attr(b.successor)}/></branch>'
            for b in transition.branches
        ]
    lines.append("      </transition>")
    return lines


def _platform(line: PlatformLine) -> str:
    return f'    <platform id="{id_ranges(line.ids)}" actor={_attr(line.actor)}/>'


def to_xml(script: TaskScript) -> str:
    """The canonical task-script text of ``script`` (UTF-8, ending in a newline)."""
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f"<TaskScript name={_attr(script.name)} version={_attr(script.version)}>",
        "  <_ActorsConfig>",
    ]
    for actor in script.actors:
        lines += _actor(actor)
    lines += ["  </_ActorsConfig>", "  <_TaskConfig>"]
    for actor_name, transitions in script.transitions.items():
        lines.append(f"    <actor name={_attr(actor_name)}>")
        for transition in transitions:
            lines += _transition(transition)
        lines.append("    </actor>")
    lines += ["  </_TaskConfig>", "  <_PlatformActorConfig>"]
    lines += [_platform(line) for line in script.platforms]
    lines += ["  </_PlatformActorConfig>", "</TaskScript>"]
    return "\n".join(lines) + "\n"
