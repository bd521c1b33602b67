"""A platform back in the swarm after missing the swarm's events (it crashed and rebooted,
or was cut off): the master forwards it the shared events it missed that every platform of
its actor takes (``sysNum="all"``), so it follows the swarm; one that picks some platforms
(an exact ``sysNum``) was taken by those picked and is not forwarded."""

from __future__ import annotations

from typing import Any

from actorswarm.dsl import check
from actorswarm.sim.tasksim import Fault, GroundEvent, TaskSim

IDLE = (
    "<OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
    "<Plugin><_P_Name>core.idle</_P_Name></Plugin></Bus></OODAConfig>"
)


def _script(sys_num: str) -> str:
    """A -go_event-> B -back_event-> A, five platforms."""
    actors = "".join(f"<Actor><_P_Name>{a}</_P_Name>{IDLE}</Actor>" for a in ("A", "B"))
    return f"""<TaskScript name="rejoin" version="1">
  <_ActorsConfig>{actors}</_ActorsConfig>
  <_TaskConfig>
    <actor name="A">
      <transition name="go_event" barrierKey="1" sysNum="{sys_num}">
        <successor actor="B"/>
      </transition>
    </actor>
    <actor name="B">
      <transition name="back_event" barrierKey="2" sysNum="all">
        <successor actor="A"/>
      </transition>
    </actor>
  </_TaskConfig>
  <_PlatformActorConfig><platform id="1-5" actor="A"/></_PlatformActorConfig>
</TaskScript>"""


def _report(
    sys_num: str, killed: int, *, back: float | None = None, restart: float = 5.0
) -> dict[str, Any]:
    """Platform ``killed`` dies at 2 s, before go_event (3 s), and reboots at ``restart``;
    ``back``: when back_event brings the swarm back to A."""
    result = check(_script(sys_num), path="rejoin.xml")
    assert result.ok and result.script is not None, [str(d) for d in result.diagnostics]
    sim = TaskSim(result.script, seed=5)
    events = [GroundEvent("go_event", 3.0)]
    if back is not None:
        events.append(GroundEvent("back_event", back))
    report = sim.run(
        12.0,
        events=events,
        faults=[
            Fault("kill", 2.0, frozenset({killed})),
            Fault("restart", restart, frozenset({killed})),
        ],
    )
    assert report["violations"] == []
    return report


def _run(sys_num: str, killed: int) -> dict[str, list[str]]:
    final: dict[str, list[str]] = _report(sys_num, killed)["final_actors"]
    return final


def test_a_rebooted_member_follows_the_swarm_through_the_event_it_missed() -> None:
    final = _run("all", killed=4)
    assert final["4"] == ["B"], "it came back in A and was forwarded go_event"
    assert all(actors == ["B"] for actors in final.values())


def test_a_rebooted_master_follows_the_swarm_too() -> None:
    """The master itself missed it: its successor forwards it once it is back."""
    final = _run("all", killed=1)
    assert all(actors == ["B"] for actors in final.values()), final


def test_an_event_that_picked_some_platforms_is_not_forwarded() -> None:
    """sysNum="2": two of the four there went to B; the one back later stays in A."""
    final = _run("2", killed=4)
    assert final["4"] == ["A"]
    assert sum(actors == ["B"] for actors in final.values()) == 2


def test_a_platform_back_where_the_swarm_is_again_is_forwarded_nothing() -> None:
    """The swarm went to B and came back to A while platform 4 was down in A: it is where
    everyone is, and go_event (the latest that took every A platform away) is history."""
    report = _report("all", killed=4, back=5.0, restart=7.0)
    assert all(actors == ["A"] for actors in report["final_actors"].values())
    after = [r for r in report["transitions"] if r["platform"] == 4 and r["t"] >= 7.0]
    assert [r["to"] for r in after] == ["A"], after  # its resumed A, nothing else


def test_a_platform_back_while_the_swarm_is_away_follows_it_out_and_back() -> None:
    report = _report("all", killed=4, back=8.0, restart=5.0)
    assert all(actors == ["A"] for actors in report["final_actors"].values())
    after = [r["to"] for r in report["transitions"] if r["platform"] == 4 and r["t"] >= 5.0]
    assert after == ["A", "B", "A"], after


def test_a_platform_back_before_a_new_master_knows_everyone_follows_once_it_does() -> None:
    """Platform 4 misses go_event, then the master dies and 4 reboots while the new master
    gathers what its members run: 4's catch-up waits for the last of them, then goes (it
    used to be dropped, and 4 stayed in A for good)."""
    result = check(_script("all"), path="rejoin.xml")
    assert result.script is not None
    for restart in (3.6, 3.8, 4.0, 4.2):
        report = TaskSim(result.script, seed=1).run(
            12.0,
            events=[GroundEvent("go_event", 3.0)],
            faults=[
                Fault("kill", 2.0, frozenset({4})),
                Fault("kill", 3.5, frozenset({1})),
                Fault("restart", restart, frozenset({4})),
            ],
        )
        assert report["violations"] == []
        final = report["final_actors"]
        assert final["4"] == ["B"], (restart, final)
