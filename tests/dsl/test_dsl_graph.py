"""The state-machine diagrams: one edge table, drawn as Mermaid and as Graphviz dot."""

from __future__ import annotations

from pathlib import Path

from actorswarm.dsl import Edge, check, load, state_edges, to_dot, to_mermaid

BRANCH_MERGE = Path(__file__).resolve().parents[2] / "examples" / "branch_merge.xml"
PLUGINS = frozenset({"core.idle", "core.emit_after"})


def test_branch_merge_edges_carry_event_counts_and_keys() -> None:
    script = load(BRANCH_MERGE, known_plugins=PLUGINS)
    assert state_edges(script) == (
        Edge(source="[*]", target="A", label="platforms 1-10", kind="start"),
        Edge(source="A", target="B", label="AtoBC_branch_event (2 of 10, key 4)", kind="branch"),
        Edge(source="A", target="C", label="AtoBC_branch_event (8 of 10, key 4)", kind="branch"),
        Edge(source="A", target="C", label="timeout 60 s (AtoBC_branch_event)", kind="timeout"),
        Edge(source="B", target="A", label="finish_event (2, key 5)", kind="branch"),
        Edge(source="C", target="A", label="finish_event (8, key 5)", kind="branch"),
    )


def test_branch_merge_as_mermaid() -> None:
    text = to_mermaid(load(BRANCH_MERGE, known_plugins=PLUGINS))
    assert text.splitlines() == [
        "stateDiagram-v2",
        "    [*] --> A : platforms 1-10",
        "    A --> B : AtoBC_branch_event (2 of 10, key 4)",
        "    A --> C : AtoBC_branch_event (8 of 10, key 4)",
        "    A --> C : timeout 60 s (AtoBC_branch_event)",
        "    B --> A : finish_event (2, key 5)",
        "    C --> A : finish_event (8, key 5)",
    ]


def test_branch_merge_as_dot() -> None:
    text = to_dot(load(BRANCH_MERGE, known_plugins=PLUGINS))
    assert text.startswith('digraph "branch-merge" {\n') and text.endswith("}\n")
    for line in [
        '"A" [label="A", peripheries=2];',
        '"B" [label="B"];',
        '"__start__" -> "A" [label="platforms 1-10"];',
        '"A" -> "B" [label="AtoBC_branch_event (2 of 10, key 4)"];',
        '"A" -> "C" [label="AtoBC_branch_event (8 of 10, key 4)"];',
        '"A" -> "C" [label="timeout 60 s (AtoBC_branch_event)", style=dashed];',
        '"B" -> "A" [label="finish_event (2, key 5)"];',
        '"C" -> "A" [label="finish_event (8, key 5)"];',
    ]:
        assert f"    {line}\n" in text


SCRIPT = """<TaskScript name='say "hi"'>
  <_ActorsConfig>
    <Actor><_P_Name>take-off</_P_Name></Actor>
    <Actor><_P_Name>end</_P_Name></Actor>
    <Actor><_P_Name>Hover</_P_Name></Actor>
  </_ActorsConfig>
  <_TaskConfig>
    <actor name="take-off">
      <transition name="up" sysNum="all" timeout="1.5">
        <branch cnt="1"><successor actor="Hover"/></branch>
        <branch cnt="rest"><successor actor="end"/></branch>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-3,7" actor="take-off"/></_PlatformActorConfig>
</TaskScript>
"""


def test_names_mermaid_cannot_take_are_aliased() -> None:
    script = check(SCRIPT, known_plugins=PLUGINS).script
    assert script is not None
    assert to_mermaid(script).splitlines() == [
        "stateDiagram-v2",
        '    state "take-off" as actor_1',
        '    state "end" as actor_2',
        "    [*] --> actor_1 : platforms 1-3,7",
        "    actor_1 --> Hover : up (1 of all)",
        "    actor_1 --> actor_2 : up (rest of all)",
        "    actor_1 --> actor_1 : timeout 1.5 s (up)",
    ]


def test_dot_quotes_what_it_must() -> None:
    script = check(SCRIPT, known_plugins=PLUGINS).script
    assert script is not None
    text = to_dot(script)
    assert text.startswith('digraph "say \\"hi\\"" {')
    assert '    "take-off" -> "take-off" [label="timeout 1.5 s (up)", style=dashed];\n' in text
