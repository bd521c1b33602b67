"""Task-engine scenarios on the simulated swarm: every behaviour of docs/design.md §4.1.

Each test writes a small script (or uses a shipped example), runs it with
:class:`~actorswarm.sim.tasksim.TaskSim`, and asserts the switches it made and that the core's
invariants held. Failures name the seed.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from actorswarm.core.config import CoreConfig
from actorswarm.dsl import check, load
from actorswarm.dsl.model import TaskScript
from actorswarm.engine.promotion import BID_WINDOW
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

ACTOR = """<Actor><_P_Name>{name}</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>"""
EMITTER = """<Actor><_P_Name>{name}</_P_Name><OODAConfig><Bus><_P_Name>decide_bus</_P_Name>
<Plugin><_P_Name>core.emit_after</_P_Name><param key="event" value="{event}"/>
<param key="after" value="{after}"/><param key="spread_per_platform" value="{spread}"/>
<param key="scope" value="{scope}"/></Plugin></Bus></OODAConfig></Actor>"""


def script(actors: str, task: str, platforms: str) -> TaskScript:
    text = (
        f'<TaskScript name="t" version="1"><_ActorsConfig>{actors}</_ActorsConfig>'
        f"<_TaskConfig>{task}</_TaskConfig>"
        f"<_PlatformActorConfig>{platforms}</_PlatformActorConfig></TaskScript>"
    )
    result = check(text, path="t.xml")
    assert result.ok, "\n".join(str(d) for d in result.diagnostics)
    assert result.script is not None
    return result.script


def switches(report: dict[str, Any]) -> list[dict[str, Any]]:
    return [t for t in report["transitions"] if t["cause"] not in ("start", "lost")]


def clean(report: dict[str, Any]) -> None:
    assert report["violations"] == [], report["violations"]


def test_shared_branch_merge_example_branches_and_merges_on_one_release_each() -> None:
    sim = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=0)
    report = sim.run(
        15,
        events=[GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 10.0)],
    )
    clean(report)
    out = switches(report)
    branch = [t for t in out if t["event"] == "AtoBC_branch_event"]
    merge = [t for t in out if t["event"] == "finish_event"]
    assert Counter(t["to"] for t in branch) == {"B": 2, "C": 8}
    assert all(t["cause"] == "barrier" for t in out)
    # One release: every switch of a step within one round trip of the first.
    assert max(t["t"] for t in branch) - min(t["t"] for t in branch) <= 0.025
    assert Counter(t["to"] for t in merge) == {"A": 10}
    assert max(t["t"] for t in merge) - min(t["t"] for t in merge) <= 0.025
    # The best bids (the lowest IDs by default) fill the first branch.
    assert sorted(t["platform"] for t in branch if t["to"] == "B") == [1, 2]
    assert report["final_actors"] == {str(p): ["A"] for p in range(1, 11)}


def test_ready_barrier_fires_once_the_last_is_ready() -> None:
    report = TaskSim(load(EXAMPLES / "ready_barrier.xml"), seed=1).run(10)
    clean(report)
    out = switches(report)
    assert len(out) == 10 and {t["to"] for t in out} == {"Ingress"}
    # Platform p is ready at 2 + 0.1 p: the last, platform 10, at 3.0 s.
    assert all(3.0 <= t["t"] <= 3.05 for t in out), [t["t"] for t in out]
    assert report["completed"] is True


def test_sysnum_all_adapts_to_a_platform_that_left() -> None:
    sim = TaskSim(load(EXAMPLES / "ready_barrier.xml"), seed=2)
    report = sim.run(10, faults=[Fault("kill", 1.0, frozenset({10}))])
    clean(report)
    out = switches(report)
    assert sorted(t["platform"] for t in out) == list(range(1, 10))
    lost = [t for t in report["transitions"] if t["cause"] == "lost"]
    assert [(t["platform"], t["from"], t["to"], t["t"]) for t in lost] == [(10, "Standby", "", 1.0)]
    # Platform 9 is the last ready (2.9 s): nobody waits for the dead 10 until a timeout.
    assert all(t["cause"] == "barrier" and t["t"] < 3.0 for t in out)


def test_timeout_sends_the_waiting_candidates_to_the_timeout_branch() -> None:
    s = script(
        ACTOR.format(name="Loiter") + ACTOR.format(name="Go") + ACTOR.format(name="Back"),
        '<actor name="Loiter"><transition name="go" barrierKey="3" sysNum="5" timeout="4" '
        'timeoutBranch="Back"><successor actor="Go"/></transition></actor>',
        '<platform id="1-5" actor="Loiter"/>',
    )
    run = TaskSim(s, seed=3)
    report = run.run(12, events=[GroundEvent("go", 2.0, frozenset({1, 2}))])
    clean(report)
    out = switches(report)
    assert sorted(t["platform"] for t in out) == [1, 2]
    assert all(t["to"] == "Back" and t["cause"] == "timeout" for t in out)
    assert all(6.0 <= t["t"] <= 6.1 for t in out), "the master times out 4 s after the request"
    # Each leaves with its own place among those who waited (a formation's slot).
    places = sorted(
        (run.hosts[p].engine.runtime.acbs()["Back"].context.slot,
         run.hosts[p].engine.runtime.acbs()["Back"].context.slots)
        for p in (1, 2)
    )  # fmt: skip
    assert places == [(1, 2), (2, 2)]


def test_more_candidates_than_sysnum_best_bids_win_the_rest_stay() -> None:
    s = script(
        ACTOR.format(name="A") + ACTOR.format(name="B"),
        '<actor name="A"><transition name="pick" sysNum="3"><successor actor="B"/></transition>'
        "</actor>",
        '<platform id="1-6" actor="A"/>',
    )
    report = TaskSim(s, seed=4).run(5, events=[GroundEvent("pick", 2.0)])
    clean(report)
    assert sorted(t["platform"] for t in switches(report)) == [1, 2, 3]
    assert report["final_actors"]["6"] == ["A"]


def test_groups_sharing_a_key_fire_together_and_wait_for_each_other() -> None:
    s = script(
        ACTOR.format(name="B") + ACTOR.format(name="C") + ACTOR.format(name="A"),
        '<actor name="B"><transition name="done" barrierKey="5" sysNum="2">'
        '<successor actor="A"/></transition></actor>'
        '<actor name="C"><transition name="done" barrierKey="5" sysNum="3">'
        '<successor actor="A"/></transition></actor>',
        '<platform id="1-2" actor="B"/><platform id="3-5" actor="C"/>',
    )
    report = TaskSim(s, seed=5).run(
        8,
        events=[GroundEvent("done", 2.0, frozenset({1, 2})), GroundEvent("done", 4.0)],
    )
    clean(report)
    out = switches(report)
    assert len(out) == 5 and all(t["to"] == "A" for t in out)
    assert all(4.0 <= t["t"] <= 4.05 for t in out), "B waited for C: one release at 4 s"


def test_swarm_scope_event_from_a_plugin_makes_everyone_a_candidate() -> None:
    s = script(
        EMITTER.format(name="Watch", event="seen", after="1", spread="0", scope="swarm")
        + ACTOR.format(name="Idle")
        + ACTOR.format(name="Track"),
        '<actor name="Idle"><transition name="seen" sysNum="all"><successor actor="Track"/>'
        "</transition></actor>",
        '<platform id="1" actor="Watch"/><platform id="2-6" actor="Idle"/>',
    )
    report = TaskSim(s, seed=6).run(5)
    clean(report)
    out = switches(report)
    assert sorted(t["platform"] for t in out) == [2, 3, 4, 5, 6]
    ignored = {(e["platform"], e["event"]) for e in report["ignored_events"]}
    assert (1, "seen") in ignored, "the emitter has no transition for it: logged as ignored"


def test_lost_actor_promotes_exactly_one_replacement() -> None:
    sim = TaskSim(load(EXAMPLES / "reorganize_lost.xml"), seed=7)
    report = sim.run(10, faults=[Fault("kill", 3.0, frozenset({1}))])
    clean(report)
    out = switches(report)
    assert len(out) == 1 and out[0]["to"] == "Track" and out[0]["event"] == "Track_lost"
    # Noticed within T_leave and a handshake; the master then lets the bids gather.
    assert out[0]["t"] - 3.0 <= 0.7 + BID_WINDOW


def test_a_lost_member_that_was_not_master() -> None:
    s = script(
        ACTOR.format(name="Track") + ACTOR.format(name="Range"),
        '<actor name="Range"><transition name="Track_lost" sysNum="1">'
        '<successor actor="Track"/></transition></actor>',
        '<platform id="4" actor="Track"/><platform id="1-3" actor="Range"/>',
    )
    report = TaskSim(s, seed=8).run(6, faults=[Fault("kill", 2.0, frozenset({4}))])
    clean(report)
    out = switches(report)
    assert [(t["platform"], t["to"]) for t in out] == [(1, "Track")], out


def test_master_crash_in_the_middle_of_a_barrier_group() -> None:
    # Everyone is a candidate of a group that needs all of them; the master dies before the
    # last candidate asks. The next master fires the group without it.
    s = script(
        EMITTER.format(name="Wait", event="ready", after="1", spread="0.2", scope="local")
        + ACTOR.format(name="Go"),
        '<actor name="Wait"><transition name="ready" barrierKey="1" sysNum="all">'
        '<successor actor="Go"/></transition></actor>',
        '<platform id="1-6" actor="Wait"/>',
    )
    report = TaskSim(s, seed=9).run(8, faults=[Fault("kill", 1.5, frozenset({1}))])
    clean(report)
    out = switches(report)
    assert sorted(t["platform"] for t in out) == [2, 3, 4, 5, 6]
    assert len({round(t["t"], 1) for t in out}) == 1, "one release"
    assert [m["platform"] for m in report["masters"]] == [1, 2]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_branch_merge_under_thirty_percent_loss(seed: int) -> None:
    sim = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=seed, link=LinkModel(loss=0.3))
    report = sim.run(
        20, events=[GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 12.0)]
    )
    clean(report)
    branch = [t for t in switches(report) if t["event"] == "AtoBC_branch_event"]
    assert Counter(t["to"] for t in branch) == {"B": 2, "C": 8}, f"seed {seed}: {branch}"
    assert report["final_actors"] == {str(p): ["A"] for p in range(1, 11)}, f"seed {seed}"


def test_partition_that_heals() -> None:
    sim = TaskSim(load(EXAMPLES / "ready_barrier.xml"), seed=10)
    report = sim.run(
        12,
        faults=[Fault("partition", 1.0, frozenset({8, 9, 10})), Fault("heal", 6.0)],
    )
    clean(report)
    out = switches(report)
    # Each side fires on its own (sysNum="all" counts the holders each master sees).
    assert sorted(t["platform"] for t in out) == list(range(1, 11))
    assert {t["to"] for t in out} == {"Ingress"}
    assert len({m["platform"] for m in report["masters"]}) >= 2


def test_candidate_that_cannot_reach_any_master_falls_back_alone() -> None:
    # The platforms never hear each other (no master can be elected in time: a long boot
    # wait), so the candidate decides alone after timeout + grace.
    s = script(
        ACTOR.format(name="Loiter") + ACTOR.format(name="Go") + ACTOR.format(name="Back"),
        '<actor name="Loiter"><transition name="go" barrierKey="3" sysNum="2" timeout="2" '
        'timeoutBranch="Back"><successor actor="Go"/></transition></actor>',
        '<platform id="1-2" actor="Loiter"/>',
    )
    config = CoreConfig(boot_wait=100.0)
    report = TaskSim(s, seed=11, config=config).run(
        8, events=[GroundEvent("go", 1.0, frozenset({1}))]
    )
    out = switches(report)
    grace = config.t_leave + config.t_join
    assert [(t["platform"], t["to"], t["cause"]) for t in out] == [(1, "Back", "timeout")]
    assert out[0]["t"] == pytest.approx(1.0 + 2.0 + grace, abs=0.01)


def test_events_without_a_transition_are_ignored_and_logged() -> None:
    report = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=12).run(
        3, events=[GroundEvent("finish_event", 1.0, frozenset({1}))]
    )
    clean(report)
    assert switches(report) == []
    assert {(e["platform"], e["event"]) for e in report["ignored_events"]} == {(1, "finish_event")}


def test_same_seed_gives_the_same_report() -> None:
    def run() -> dict[str, Any]:
        sim = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=13, link=LinkModel(loss=0.2))
        return sim.run(
            14,
            events=[GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 10.0)],
            faults=[Fault("kill", 7.0, frozenset({1}))],
        )

    assert run() == run()


@pytest.mark.parametrize("seed", [0, 1])
def test_the_branch_merge_example_as_its_comment_says(seed: int) -> None:
    report = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=seed).run(
        15, events=[GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 10.0)]
    )
    clean(report)
    moves = Counter((t["from"], t["to"]) for t in switches(report))
    assert moves == {("A", "B"): 2, ("A", "C"): 8, ("B", "A"): 2, ("C", "A"): 8}


def test_the_ready_barrier_example_as_its_comment_says() -> None:
    report = TaskSim(load(EXAMPLES / "ready_barrier.xml"), seed=0).run(10)
    clean(report)
    out = switches(report)
    assert len(out) == 10 and all(2.95 <= t["t"] <= 3.1 for t in out)


def test_a_merge_of_two_parts_numbers_the_successor_s_slots_across_both() -> None:
    """The paper's merge (B and C into one actor on one key): one slot per member, counted
    over both parts, so a formation flown by the merged group has no shared slot."""
    sim = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=3)
    sim.run(12, events=[GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 9)])
    contexts = [h.engine.runtime.acbs()["A"].context for h in sim.hosts.values()]
    assert sorted(c.slot for c in contexts) == list(range(1, 11))
    assert {c.slots for c in contexts} == {10}
    assert {c.size for c in contexts} == {2, 8}, "size stays the size of the platform's part"


def test_successor_gets_the_params_its_index_and_the_scattered_data() -> None:
    sim = TaskSim(load(EXAMPLES / "branch_merge.xml"), seed=14)
    sim.run(7, events=[GroundEvent("AtoBC_branch_event", 5.0)])
    acbs = {p: h.engine.runtime.acbs() for p, h in sim.hosts.items()}
    b = acbs[1]["B"].context
    assert b.params == {"TargetPoint": "200 200 20"}
    assert b.index == 1 and b.data == {"to": "B", "slot": 1, "slots": 2}
    assert (b.size, b.slot, b.slots) == (10, 1, 2)
    c = acbs[10]["C"].context
    assert c.index == 10 and c.data == {"to": "C", "slot": 8, "slots": 8}, (
        "indices run over the group in bid order; slots over the branch"
    )
    assert (c.size, c.slot, c.slots) == (10, 8, 8)
    assert acbs[1]["A"].status.value == "sleeping", "switch pauses the actor it leaves"
