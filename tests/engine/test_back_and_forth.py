"""Two actors the swarm goes back and forth between, on the same two barrier keys.

A switch pauses the actor it leaves, and a switch back re-activates it with its plugins'
state (docs/design.md §5); ``core.emit_after`` emits once per *start* and only counts
running time. So a ``Watch ⇄ Found`` pair whose way back is ``core.emit_after`` in
``Found`` switches Watch → Found → Watch → Found and then stays in ``Found``: the second
entry re-activates the timer that already fired. These tests pin that, and that the same
script goes on for as long as it runs when the way back counts again on every entry
(docs/task-scripts.md, "Going back to an actor").
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import pytest

from actorswarm.bench.alternate import EMIT_ON_ENTRY
from actorswarm.dsl import check
from actorswarm.dsl.model import TaskScript
from actorswarm.sim.radio import LinkModel
from actorswarm.sim.tasksim import GroundEvent, TaskSim

#: ``seen_event`` (from the ground station, or ``WATCH_TIMER``) takes every platform from
#: Watch to Found on key 1; ``back_event``, 0.5 s after Found is entered, takes them back
#: on key 2: the shape of the ROS 2 latency measurement, with the ground station as the
#: sensor.
PAIR = """<TaskScript name="pair" version="1"><_ActorsConfig>
<Actor><_P_Name>Watch</_P_Name><OODAConfig><Bus><_P_Name>observe_bus</_P_Name>{watch}
</Bus></OODAConfig></Actor>
<Actor><_P_Name>Found</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
<Plugin><_P_Name>{back}</_P_Name><param key="event" value="back_event"/>
<param key="after" value="0.5"/><param key="scope" value="{scope}"/></Plugin>
</Bus></OODAConfig></Actor>
</_ActorsConfig><_TaskConfig>
<actor name="Watch"><transition name="seen_event" barrierKey="1" sysNum="all">
<successor actor="Found"/></transition></actor>
<actor name="Found"><transition name="back_event" barrierKey="2" sysNum="all">
<successor actor="Watch"/></transition></actor>
</_TaskConfig><_PlatformActorConfig><platform id="1-{size}" actor="Watch"/>
</_PlatformActorConfig></TaskScript>"""
WATCH_IDLE = "<Plugin><_P_Name>core.idle</_P_Name></Plugin>"
WATCH_TIMER = (
    f'<Plugin><_P_Name>{EMIT_ON_ENTRY}</_P_Name><param key="event" value="seen_event"/>'
    '<param key="after" value="1.0"/><param key="scope" value="swarm"/></Plugin>'
)


def pair(size: int, back: str, scope: str, watch: str = WATCH_IDLE) -> TaskScript:
    result = check(PAIR.format(size=size, back=back, scope=scope, watch=watch), path="pair.xml")
    assert result.ok, "\n".join(str(d) for d in result.diagnostics)
    assert result.script is not None
    return result.script


def sightings(until: float, every: float = 1.5, twice: bool = False) -> list[GroundEvent]:
    """``seen_event`` to every platform from 2 s on, every ``every`` seconds (``twice``: a
    second one 20 ms after each, while the first one's switch is still on its way)."""
    out = []
    t = 2.0
    while t < until:
        out.append(GroundEvent("seen_event", t))
        if twice:
            out.append(GroundEvent("seen_event", t + 0.02))
        t += every
    return out


def moves(report: dict[str, Any], platform: int) -> list[tuple[str, str]]:
    return [
        (t["from"], t["to"])
        for t in report["transitions"]
        if t["platform"] == platform and t["cause"] == "barrier"
    ]


@pytest.mark.parametrize("size", [2, 5])
@pytest.mark.parametrize("scope", ["local", "swarm"])
def test_core_emit_after_takes_the_swarm_back_once_then_found_waits(size: int, scope: str) -> None:
    sim = TaskSim(pair(size, "core.emit_after", scope), seed=size)
    events = sightings(11)
    report = sim.run(12, events=events)
    assert report["violations"] == []
    for p in range(1, size + 1):
        assert moves(report, p) == [("Watch", "Found"), ("Found", "Watch"), ("Watch", "Found")]
        # The second entry re-activated the instance of the first: its timer has fired.
        (timer,) = sim.hosts[p].engine.runtime.plugins("Found")
        assert timer.snapshot()["fired"] is True
    assert report["waiting"] == {"Found": ["back_event"]}
    assert report["final_actors"] == {str(p): ["Found"] for p in range(1, size + 1)}
    # Every later sighting finds the swarm in Found: nothing is lost in the core.
    late = Counter(e["platform"] for e in report["ignored_events"] if e["event"] == "seen_event")
    assert late == {p: len(events) - 2 for p in range(1, size + 1)}


@pytest.mark.parametrize("size", [2, 5])
@pytest.mark.parametrize("scope", ["local", "swarm"])
@pytest.mark.parametrize("twice", [False, True])
def test_a_way_back_that_counts_on_every_entry_goes_back_every_time(
    size: int, scope: str, twice: bool
) -> None:
    events = sightings(19, twice=twice)
    report = TaskSim(pair(size, EMIT_ON_ENTRY, scope), seed=size).run(20, events=events)
    assert report["violations"] == []
    rounds = len(sightings(19))  # 12: one round trip per sighting, a repeat changes nothing
    for p in range(1, size + 1):
        assert moves(report, p) == [("Watch", "Found"), ("Found", "Watch")] * rounds


@pytest.mark.parametrize("seed", [0, 1])
def test_both_ways_on_timers_go_on_under_loss(seed: int) -> None:
    """Watch's own timer (a swarm event) and Found's, 20 % loss: still a round trip about
    every 1.6 s on every platform, where core.emit_after's pair stops after 1."""
    script = pair(5, EMIT_ON_ENTRY, "swarm", watch=WATCH_TIMER)
    report = TaskSim(script, seed=seed, link=LinkModel(loss=0.2)).run(20)
    assert report["violations"] == []
    for p in range(1, 6):
        back = moves(report, p).count(("Found", "Watch"))
        assert back >= 10, (seed, p, moves(report, p))
