"""What a transition group waits for (docs/task-scripts.md, "What a group waits for").

A group fires when every part that can have candidates has its ``sysNum`` of them: a part
whose actor nobody runs (``all``), or nobody runs or can still reach (a number), holds the
group back from nothing; a part emptied by a loss stops holding it back; a platform that
enters a part's actor while the group waits is forwarded the group's shared event and
becomes a candidate. Each case would otherwise wait for the group's timeout (30 s here).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from actorswarm.core.wire import NEED_ALL
from actorswarm.dsl import check, load
from actorswarm.dsl.model import TaskScript
from actorswarm.engine.machine import ActorMachine
from actorswarm.engine.plan import Plan
from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim
from actorswarm.world.config import loads_world

ROOT = Path(__file__).resolve().parents[2]

IDLE = """<Actor><_P_Name>{}</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig></Actor>"""
TIMEOUT = 30.0


def script(task: str, platforms: str, actors: str = "A B C X Y") -> TaskScript:
    text = (
        '<TaskScript name="t" version="1"><_ActorsConfig>'
        + "".join(IDLE.format(a) for a in actors.split())
        + f"</_ActorsConfig><_TaskConfig>{task}</_TaskConfig>"
        f"<_PlatformActorConfig>{platforms}</_PlatformActorConfig></TaskScript>"
    )
    result = check(text, path="t.xml")
    assert result.ok, "\n".join(str(d) for d in result.diagnostics)
    assert result.script is not None
    return result.script


def recall(b_num: str = "all") -> str:
    """Group 1 on ``recall``: A (all) and B (``b_num``) both to C; X may enter B."""
    return (
        f'<actor name="A"><transition name="recall" barrierKey="1" sysNum="all" '
        f'timeout="{TIMEOUT:g}" timeoutBranch="Y"><successor actor="C"/></transition></actor>'
        f'<actor name="B"><transition name="recall" barrierKey="1" sysNum="{b_num}" '
        f'timeout="{TIMEOUT:g}" timeoutBranch="Y"><successor actor="C"/></transition></actor>'
        '<actor name="X"><transition name="go_b" sysNum="1">'
        '<successor actor="B"/></transition></actor>'
    )


def run(sc: TaskScript, duration: float, seed: int = 0, **kw: Any) -> dict[str, Any]:
    report: dict[str, Any] = TaskSim(sc, seed=seed).run(duration, **kw)
    assert report["violations"] == [], report["violations"]
    return report


def to_c(report: dict[str, Any]) -> list[dict[str, Any]]:
    return [t for t in report["transitions"] if t["to"] == "C"]


def test_a_part_whose_actor_nobody_runs_does_not_hold_the_group_back() -> None:
    sc = script(recall(), '<platform id="1-4" actor="A"/>')
    report = run(sc, 8, events=[GroundEvent("recall", 5.0)])
    moved = to_c(report)
    assert sorted(t["platform"] for t in moved) == [1, 2, 3, 4]
    assert all(t["cause"] == "barrier" and 5.0 <= t["t"] < 5.5 for t in moved), moved


def test_a_part_emptied_by_a_loss_stops_holding_the_group_back() -> None:
    # Platform 4 runs B and never hears the recall; it dies at 7 s.
    sc = script(recall(), '<platform id="1-3" actor="A"/><platform id="4" actor="B"/>')
    report = run(
        sc,
        12,
        events=[GroundEvent("recall", 5.0, frozenset({1, 2, 3}))],
        faults=[Fault("kill", 7.0, frozenset({4}))],
    )
    moved = to_c(report)
    assert sorted(t["platform"] for t in moved) == [1, 2, 3]
    # Held while B had a holder; released once the master declared it gone (t_leave 0.5 s
    # plus probing), long before the 30 s timeout.
    assert all(t["cause"] == "barrier" and 7.0 < t["t"] < 9.0 for t in moved), moved


def test_a_platform_entering_a_part_while_the_group_waits_is_forwarded_the_event() -> None:
    # B needs 1 candidate; nobody runs B, but platform 3 runs X, which can switch to B:
    # the group waits; 3 enters B at 8 s, is forwarded the recall and joins the firing.
    sc = script(recall("1"), '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>')
    report = run(
        sc,
        12,
        events=[GroundEvent("recall", 5.0), GroundEvent("go_b", 8.0, frozenset({3}))],
    )
    moved = to_c(report)
    assert sorted(t["platform"] for t in moved) == [1, 2, 3]
    assert all(t["cause"] == "barrier" and 8.0 < t["t"] < 8.5 for t in moved), moved
    assert len({round(t["t"], 1) for t in moved}) == 1, "one firing for all three"


def test_a_numeric_part_on_an_actor_nobody_can_reach_does_not_hold_the_group_back() -> None:
    # Platform 3 runs Y, from which no transition leads to B.
    sc = script(recall("1"), '<platform id="1-2" actor="A"/><platform id="3" actor="Y"/>')
    report = run(sc, 8, events=[GroundEvent("recall", 5.0)])
    moved = to_c(report)
    assert sorted(t["platform"] for t in moved) == [1, 2]
    assert all(t["cause"] == "barrier" and t["t"] < 5.5 for t in moved), moved


def test_a_numeric_part_stops_waiting_when_the_last_platform_that_could_reach_it_is_lost() -> None:
    sc = script(recall("1"), '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>')
    report = run(
        sc,
        12,
        events=[GroundEvent("recall", 5.0)],
        faults=[Fault("kill", 7.0, frozenset({3}))],
    )
    moved = to_c(report)
    assert sorted(t["platform"] for t in moved) == [1, 2]
    assert all(t["cause"] == "barrier" and 7.0 < t["t"] < 9.0 for t in moved), moved


def test_a_group_with_a_part_that_can_be_filled_still_waits_for_it_until_its_timeout() -> None:
    # The other side of the rule: B is reachable (3 runs X) and 3 never enters it, so the
    # group waits for its timeout, and the candidates take the timeout branch.
    sc = script(recall("1"), '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>')
    report = run(sc, 5.0 + TIMEOUT + 2, events=[GroundEvent("recall", 5.0)])
    assert to_c(report) == []
    timed = [t for t in report["transitions"] if t["cause"] == "timeout"]
    assert Counter(t["to"] for t in timed) == {"Y": 2}
    assert all(5.0 + TIMEOUT <= t["t"] < 5.0 + TIMEOUT + 1 for t in timed), timed


def test_the_search_track_recall_fires_on_its_event_in_a_world_without_a_target() -> None:
    # Nobody ever becomes a tracker: the recall group's Track part has no holder.
    text = (ROOT / "examples" / "worlds" / "search_track_10.toml").read_text()
    targets, areas = text.index("[[targets]]"), text.index("[[areas]]")
    sc = load(ROOT / "examples" / "search_track_10.xml")
    sim = TaskSim(sc, seed=0, world_config=loads_world(text[:targets] + text[areas:]))
    report = sim.run(62, events=[GroundEvent("go_home_event", 60.0)])
    assert report["violations"] == [], report["violations"]
    home = [t for t in report["transitions"] if t["to"] == "Return"]
    assert len(home) == 10
    assert all(t["cause"] == "barrier" and 60.0 <= t["t"] < 60.5 for t in home), home


def test_the_needs_the_master_keeps_are_those_a_fresh_pass_over_the_live_platforms_gives(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # The master keeps each part's need until its table or its view changes (a switch of N
    # would otherwise cost O(N²)). Every answer it gives is checked against a fresh pass,
    # over the scenarios above where the table and the view change while a group waits.
    kept = Counter[str]()
    original = ActorMachine._need

    def checking(self: ActorMachine, key: int, part: int, count: int) -> int:
        stamp = (self._table_version, self.node.members.version)
        hit = stamp == self._needs_for and (key, part, count) in self._needs
        answer = original(self, key, part, count)
        fresh = self._resolve(key, part, count)
        assert answer == fresh, (self.node.platform, key, part, count, answer, fresh)
        kept["kept" if hit else "worked out"] += 1
        return answer

    monkeypatch.setattr(ActorMachine, "_need", checking)
    sc = script(recall("1"), '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>')
    run(
        sc,
        12,
        events=[GroundEvent("recall", 5.0), GroundEvent("go_b", 8.0, frozenset({3}))],
    )
    sc = script(recall(), '<platform id="1-3" actor="A"/><platform id="4" actor="B"/>')
    run(
        sc,
        12,
        events=[GroundEvent("recall", 5.0, frozenset({1, 2, 3}))],
        faults=[Fault("kill", 7.0, frozenset({4}))],
    )
    # B (all) gains a holder while the group waits for platform 4, which never heard it.
    sc = script(recall(), '<platform id="1-2" actor="A"/><platform id="3" actor="X"/>'
                '<platform id="4" actor="A"/>')  # fmt: skip
    run(
        sc,
        10,
        events=[
            GroundEvent("recall", 5.0, frozenset({1, 2})),
            GroundEvent("go_b", 6.0, frozenset({3})),
        ],
    )
    # Both paths taken: answers kept between changes, and worked out again after them.
    assert kept["kept"] > 0 and kept["worked out"] > 2, kept


def test_a_new_script_drops_the_needs_the_master_kept() -> None:
    # Group 1's first part is A (all) in the running script and Y (all), which nobody runs,
    # in the next version; the table and the view stay as they were when the plan changes.
    first = script(recall(), '<platform id="1-4" actor="A"/>')
    sim = TaskSim(first, seed=0)
    sim.run(3.0)
    (master,) = [h.engine.machine for h in sim.hosts.values() if h.engine.node.is_master]
    assert master._need(1, 0, NEED_ALL) == 4  # kept from now on
    nxt = script(
        '<actor name="Y"><transition name="recall" barrierKey="1" sysNum="all">'
        '<successor actor="C"/></transition></actor>',
        '<platform id="1-4" actor="A"/>',
    )
    master.plan = Plan.build(nxt)
    assert master._need(1, 0, NEED_ALL) == master._resolve(1, 0, NEED_ALL) == 0
