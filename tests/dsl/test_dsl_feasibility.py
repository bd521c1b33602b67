"""Barrier groups that can never fire, found from the platform lines and the transitions
(see actorswarm.dsl.feasibility): threads of actors per platform, holders that must exist
before a group fires, and a maximum flow for the demands of a group taken together."""

from __future__ import annotations

import time

from actorswarm.dsl import check
from actorswarm.dsl.feasibility import max_flow

PLUGINS = frozenset({"core.idle"})


def script(transitions: str, platforms: str, actors: str = "A B C X Y") -> str:
    defined = "".join(f"<Actor><_P_Name>{a}</_P_Name></Actor>" for a in actors.split())
    return (
        f'<TaskScript name="t"><_ActorsConfig>{defined}</_ActorsConfig>'
        f"<_TaskConfig>{transitions}</_TaskConfig>"
        f"<_PlatformActorConfig>{platforms}</_PlatformActorConfig></TaskScript>"
    )


def on(actor: str, event: str, to: str, sys_num: str, extra: str = "") -> str:
    return (
        f'<actor name="{actor}"><transition name="{event}" sysNum="{sys_num}" {extra}>'
        f'<successor actor="{to}"/></transition></actor>'
    )


def errors(text: str) -> list[str]:
    return [d.message for d in check(text, known_plugins=PLUGINS).errors]


def test_max_flow_of_a_small_network() -> None:
    capacity = {
        "s": {"a": 3, "b": 2},
        "a": {"b": 1, "t": 2},
        "b": {"t": 3},
    }
    assert max_flow(capacity, "s", "t") == 5
    assert max_flow({"s": {"a": 1}}, "s", "t") == 0


def test_a_platform_with_two_lines_serves_two_transitions_of_a_group() -> None:
    group = on("A", "go", "B", "2", 'barrierKey="1"') + on("X", "go", "Y", "2", 'barrierKey="1"')
    two_threads = '<platform id="1-2" actor="A"/><platform id="1-2" actor="X"/>'
    assert errors(script(group, two_threads)) == []
    one_thread_each = '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>'
    (message,) = errors(script(group, one_thread_each))
    assert "barrier group 1 can never fire" in message
    assert "only 1 can ever run it (3)" in message


def test_a_platform_is_one_candidate_per_transition() -> None:
    # Both lines of platforms 1-2 can reach C, but a platform runs C once: 2 holders at most.
    transitions = on("A", "a", "C", "1") + on("X", "x", "C", "1") + on("C", "c", "A", "3")
    lines = '<platform id="1-2" actor="A"/><platform id="1-2" actor="X"/>'
    (message,) = errors(script(transitions, lines))
    assert "it needs 3 platforms running C at once, but only 2 can ever run it (1-2)" in message


def test_holders_reached_only_by_a_timeout_of_the_group_count() -> None:
    # B is entered only through group 1; its timeoutBranch still gets there without a firing.
    transitions = on("A", "go", "C", "2", 'barrierKey="1" timeout="5" timeoutBranch="B"') + on(
        "B", "back", "A", "1", 'barrierKey="1"'
    )
    assert errors(script(transitions, '<platform id="1-3" actor="A"/>', "A B C")) == []


def test_the_demands_of_a_group_together_exceed_the_platforms() -> None:
    # A is entered again (z), so no count caps B or C below 5; but the group needs 2 B's and
    # 4 C's at once from 5 platforms with one thread each.
    transitions = (
        '<actor name="A"><transition name="x" sysNum="1"><successor actor="B"/></transition>'
        '<transition name="y" sysNum="1"><successor actor="C"/></transition>'
        '<transition name="z" sysNum="1"><successor actor="A"/></transition></actor>'
        + on("B", "fin", "X", "2", 'barrierKey="9"')
        + on("C", "fin", "X", "4", 'barrierKey="9"')
    )
    (message,) = errors(script(transitions, '<platform id="1-5" actor="A"/>'))
    assert (
        "barrier group 9 can never fire: its transitions need 6 platforms at once (2 running B "
        "for fin, 4 running C for fin), but at most 5 of the platforms" in message
    )


def test_sys_num_all_needs_at_least_the_integer_counts() -> None:
    transitions = (
        '<actor name="A"><transition name="go" sysNum="all">'
        '<branch cnt="4"><successor actor="B"/></branch>'
        '<branch cnt="rest"><successor actor="C"/></branch></transition></actor>'
    )
    (message,) = errors(script(transitions, '<platform id="1-3" actor="A"/>', "A B C"))
    assert "it needs at least 4 platforms running A at once, but only 3" in message
    assert errors(script(transitions, '<platform id="1-4" actor="A"/>', "A B C")) == []


def test_a_group_of_actors_no_platform_runs_is_left_to_the_warning() -> None:
    transitions = on("B", "go", "C", "1", 'barrierKey="2"') + on(
        "C", "go", "B", "1", 'barrierKey="2"'
    )
    result = check(
        script(transitions, '<platform id="1" actor="A"/>', "A B C"), known_plugins=PLUGINS
    )
    assert result.ok
    assert {w.message.split(":")[0] for w in result.warnings} == {
        "no platform ever runs actor B",
        "no platform ever runs actor C",
    }


def test_a_full_id_range_is_checked_quickly() -> None:
    groups = "".join(
        f'<transition name="e{k}" barrierKey="{k}" sysNum="65535"><successor actor="B"/>'
        "</transition>"
        for k in range(1, 21)
    )
    transitions = f'<actor name="A">{groups}</actor>' + on("B", "back", "A", "all")
    lines = '<platform id="1-65535" actor="A"/><platform id="1-65535" actor="X"/>'
    start = time.perf_counter()
    assert errors(script(transitions, lines)) == []
    assert time.perf_counter() - start < 3.0


def test_an_actor_nothing_can_send_a_platform_to_is_said_once_where_it_starts() -> None:
    # A (3 platforms) can never fire its sysNum 5, so no platform ever reaches B: that is
    # the one error, not a second "at most 0 ever run B" at B's transition.
    transitions = on("A", "go", "B", "5") + on("B", "on", "C", "2")
    (message,) = errors(script(transitions, '<platform id="1-3" actor="A"/>', "A B C"))
    assert message.startswith("transition go of actor A can never fire: it needs 5")


GO_SPLIT = (
    '<actor name="A"><transition name="go" sysNum="all">'
    '<branch cnt="2"><successor actor="X"/></branch>'
    '<branch cnt="rest"><successor actor="Y"/></branch></transition></actor>'
)


def test_a_cycle_back_through_the_group_itself_does_not_lift_the_bound() -> None:
    # Six platforms start in A; its one release sends 2 to X. X's transition needs 4 and
    # would send them back to A: A is re-entered only through that transition, which
    # cannot fire before 4 hold X, so at most 2 ever do and the run would wait forever.
    back = on("X", "e", "A", "4")
    (message,) = errors(script(GO_SPLIT + back, '<platform id="1-6" actor="A"/>', "A X Y"))
    assert message.startswith("transition e of actor X can never fire: it needs 4 platforms")
    assert "let at most 2 ever run it" in message
    # The same cycle with a demand the branch can meet passes.
    assert errors(script(GO_SPLIT + on("X", "e", "A", "2"), '<platform id="1-6" actor="A"/>',
                         "A X Y")) == []  # fmt: skip
    # Re-entered from elsewhere (Y's own transition back to A), A is not closed: it may
    # send 2 more each time, so no bound applies.
    again = back + on("Y", "r", "A", "1")
    assert errors(script(GO_SPLIT + again, '<platform id="1-6" actor="A"/>', "A X Y")) == []
