"""Two daemons go back and forth between the same two actors on the same two barrier keys
(docs/task-scripts.md, "Going back to an actor"): with a timer that counts again on every
entry on each way, the pair keeps switching, where ``core.emit_after`` in ``Found`` stops
after one round trip (tests/engine/test_back_and_forth.py pins that in the simulator)."""

from __future__ import annotations

from pathlib import Path

from actorswarm.bench.alternate import EMIT_ON_ENTRY
from actorswarm.daemon.launch import LocalSwarm


def timer(event: str, after: float, scope: str) -> str:
    """A plugin that emits ``event`` ``after`` seconds after every entry into its actor."""
    return (
        f'<Plugin><_P_Name>{EMIT_ON_ENTRY}</_P_Name><param key="event" value="{event}"/>'
        f'<param key="after" value="{after}"/><param key="scope" value="{scope}"/></Plugin>'
    )


SCRIPT = f"""<TaskScript name="pair" version="1"><_ActorsConfig>
<Actor><_P_Name>Watch</_P_Name><OODAConfig><Bus><_P_Name>observe_bus</_P_Name>
{timer("seen_event", 1.0, "swarm")}
</Bus></OODAConfig></Actor>
<Actor><_P_Name>Found</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>
{timer("back_event", 0.5, "local")}
</Bus></OODAConfig></Actor>
</_ActorsConfig><_TaskConfig>
<actor name="Watch"><transition name="seen_event" barrierKey="1" sysNum="all">
<successor actor="Found"/></transition></actor>
<actor name="Found"><transition name="back_event" barrierKey="2" sysNum="all">
<successor actor="Watch"/></transition></actor>
</_TaskConfig><_PlatformActorConfig><platform id="1-2" actor="Watch"/>
</_PlatformActorConfig></TaskScript>
"""
ROUNDS = 3


def test_two_daemons_go_back_and_forth_on_the_same_keys(tmp_path: Path) -> None:
    path = tmp_path / "pair.xml"
    path.write_text(SCRIPT)
    with LocalSwarm(tmp_path, 2) as swarm:
        swarm.start_all()
        swarm.wait("two daemons that agree on a master", lambda: swarm.agreed_master() is not None)
        state = ["--state", str(tmp_path / "gs.json")]
        deployed = swarm.gs("deploy", str(path), "--expect", "2", *state)
        assert deployed.returncode == 0, deployed.stdout + deployed.stderr
        started = swarm.gs("start", *state)
        assert started.returncode == 0, started.stdout + started.stderr

        def back(p: int) -> int:
            return sum(1 for e in swarm.events(p, "transition") if e["on"] == "back_event")

        swarm.wait(
            f"{ROUNDS} round trips on each daemon",
            lambda: all(back(p) >= ROUNDS for p in swarm.platforms),
            timeout=30,
            detail=lambda: str({p: back(p) for p in swarm.platforms}),
        )
        for p in swarm.platforms:
            hops = [(e["on"], e["to"]) for e in swarm.events(p, "transition")]
            rounds = [("seen_event", "Found"), ("back_event", "Watch")] * ROUNDS
            assert hops[1 : 1 + 2 * ROUNDS] == rounds, (p, hops)
