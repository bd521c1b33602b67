"""The model: what the examples load into, how it is assembled from the XML, the writer's
round trip, and that it cannot be changed once built."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from actorswarm.dsl import (
    Branch,
    Param,
    PluginSpec,
    Position,
    ScriptError,
    TaskScript,
    check,
    check_file,
    installed_plugins,
    load,
    to_xml,
)

PLUGINS = installed_plugins()  # every example must check on this machine
REPO = Path(__file__).resolve().parents[2]
REPO_EXAMPLES = REPO / "examples"


def test_every_example_passes_the_checker_without_warnings(example: Path) -> None:
    result = check_file(example, known_plugins=PLUGINS)
    assert result.ok and not result.warnings, "\n".join(map(str, result.diagnostics))


def test_every_example_survives_the_round_trip(example: Path) -> None:
    script = load(example, known_plugins=PLUGINS)
    again = check(to_xml(script), known_plugins=PLUGINS)
    assert again.ok, "\n".join(map(str, again.errors))
    assert again.script == script
    assert to_xml(again.script) == to_xml(script)


def test_branch_merge_loads_into_the_expected_model() -> None:
    script = load(REPO_EXAMPLES / "branch_merge.xml", known_plugins=PLUGINS)
    assert (script.name, script.version) == ("branch-merge", "1")
    assert [(a.name, a.id, a.priority) for a in script.actors] == [
        ("A", 1, 0),
        ("B", 2, 0),
        ("C", 3, 0),
    ]
    assert script.actor("B").buses == {"act_bus": (PluginSpec(name="core.idle"),)}
    (split,) = script.transitions["A"]
    assert split.event == "AtoBC_branch_event"
    assert (split.barrier_key, split.sys_num, split.timeout, split.timeout_branch) == (
        4,
        10,
        60.0,
        "C",
    )
    assert split.params == (Param(key="TargetPoint", value="200 200 20"),)
    assert split.branches == (
        Branch(count=2, successor="B"),
        Branch(count=8, successor="C"),
    )
    (merge_b,) = script.transitions["B"]
    assert merge_b.branches == (Branch(count="rest", successor="A"),)
    assert (merge_b.barrier_key, merge_b.sys_num) == (5, 2)
    assert script.initial_actors() == {"A": frozenset(range(1, 11))}
    assert script.path == str(REPO_EXAMPLES / "branch_merge.xml")


def test_positions_are_kept_for_messages() -> None:
    script = load(REPO_EXAMPLES / "branch_merge.xml", known_plugins=PLUGINS)
    (split,) = script.transitions["A"]
    text = (REPO_EXAMPLES / "branch_merge.xml").read_text().splitlines()
    line = text[split.pos.line - 1]
    assert line[split.pos.col - 1 :].startswith('<transition name="AtoBC_branch_event"')
    key = split.at("barrierKey")
    assert text[key.line - 1][key.col - 1 :].startswith('barrierKey="4"')
    successor = split.branches[0].successor_pos
    assert text[successor.line - 1][successor.col - 1 :].startswith('actor="B"')


def test_sys_num_all_and_the_emit_after_params() -> None:
    script = load(REPO_EXAMPLES / "ready_barrier.xml", known_plugins=PLUGINS)
    (ready,) = script.transitions["Standby"]
    assert ready.sys_num == "all"
    assert ready.branches == (Branch(count="rest", successor="Ingress"),)
    ((bus, plugin),) = list(script.actor("Standby").plugins())
    assert bus == "decide_bus" and plugin.name == "core.emit_after"
    assert plugin.param_map == {
        "event": "ready_event",
        "after": "2",
        "spread_per_platform": "0.1",
        "scope": "local",
    }


SCRIPT = """<TaskScript name="ids">
  <_ActorsConfig>
    <Actor><_P_Name>X</_P_Name>
      <OODAConfig><Bus><_P_Name>observe_bus</_P_Name>
        <Plugin><_P_Name>plugin_a1</_P_Name><_P_Name>plugin_a2</_P_Name></Plugin>
      </Bus></OODAConfig>
    </Actor>
    <Actor><_P_Name>Y</_P_Name><_P_ID>1</_P_ID><_P_Prio>7</_P_Prio></Actor>
    <Actor><_P_Name>Z</_P_Name></Actor>
  </_ActorsConfig>
  <_PlatformActorConfig>
    <platform id="1,3,5-7" actor="X"/>
    <platform id="2" actor="Y"/>
    <platform id="2" actor="Z"/>
  </_PlatformActorConfig>
</TaskScript>
"""


def test_ids_are_assigned_in_order_around_the_written_ones() -> None:
    result = check(SCRIPT, known_plugins={"plugin_a1", "plugin_a2"})
    assert result.script is not None, result.errors
    assert [(a.name, a.id, a.priority) for a in result.script.actors] == [
        ("X", 2, 0),
        ("Y", 1, 7),
        ("Z", 3, 0),
    ]


def test_a_plugin_element_may_list_several_plugins() -> None:
    script = check(SCRIPT, known_plugins={"plugin_a1", "plugin_a2"}).script
    assert script is not None
    assert [p.name for p in script.actor("X").buses["observe_bus"]] == ["plugin_a1", "plugin_a2"]


def test_platform_lists_and_several_actors_per_platform() -> None:
    script = check(SCRIPT, known_plugins={"plugin_a1", "plugin_a2"}).script
    assert script is not None
    assert script.initial_actors() == {
        "X": frozenset({1, 3, 5, 6, 7}),
        "Y": frozenset({2}),
        "Z": frozenset({2}),
    }
    assert script.platform_ids() == frozenset({1, 2, 3, 5, 6, 7})


def test_load_refuses_a_broken_script_with_every_diagnostic(tmp_path: Path) -> None:
    path = tmp_path / "broken.xml"
    broken = SCRIPT.replace('id="2" actor="Y"', 'id="0" actor="Y"')
    path.write_text(broken.replace('id="2" actor="Z"', 'id="2" actor="W"'))
    with pytest.raises(ScriptError) as caught:
        load(path, known_plugins={"plugin_a1", "plugin_a2"})
    assert str(caught.value).splitlines() == [
        f"{path}:13:15: platform ID 0 is out of range: IDs go from 1 to 65535",
        f"{path}:14:22: platform 2 starts actor W, which is not defined (actors: X, Y, Z)",
    ]
    assert caught.value.errors == caught.value.diagnostics


def test_load_raises_os_error_for_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError):
        load(tmp_path / "absent.xml")


def test_the_model_cannot_be_changed() -> None:
    script = load(REPO_EXAMPLES / "branch_merge.xml", known_plugins=PLUGINS)
    with pytest.raises(dataclasses.FrozenInstanceError):
        script.name = "other"  # type: ignore[misc]
    with pytest.raises(TypeError):
        script.transitions["D"] = ()  # type: ignore[index]
    with pytest.raises(TypeError):
        script.actors[0].buses["act_bus"] = ()  # type: ignore[index]


def test_positions_take_no_part_in_equality() -> None:
    here = Branch(count=2, successor="B", pos=Position(3, 4))
    there = Branch(count=2, successor="B", pos=Position(9, 1))
    assert here == there and hash(here) == hash(there)
    assert isinstance(TaskScript(name="t", version="1", actors=()), TaskScript)


def test_the_public_surface_exists() -> None:
    from actorswarm import dsl

    missing = [name for name in dsl.__all__ if not hasattr(dsl, name)]
    assert not missing and len(set(dsl.__all__)) == len(dsl.__all__)
