"""Ten daemons and a ground station run the paper's branch-and-merge script
(``examples/branch_merge.xml``) to the outcome the simulator gives for the same
events: two B's and eight C's on one release, then ten A's on another, every platform
switching exactly once each time."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest

from actorswarm.daemon.launch import LocalSwarm
from actorswarm.dsl import load
from actorswarm.sim.tasksim import GroundEvent, TaskSim

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "branch_merge.xml"
PLATFORMS = range(1, 11)
BRANCH, MERGE = "AtoBC_branch_event", "finish_event"


def simulated() -> list[dict[str, str]]:
    """Each platform's actor after the branch and after the merge, in the simulator."""
    sim = TaskSim(load(SCRIPT), seed=1)
    sim.schedule([GroundEvent(BRANCH, 1.0), GroundEvent(MERGE, 3.0)])
    outcome = []
    for until in (2.5, 4.5):
        sim.advance(until)
        outcome.append(
            {str(p): ",".join(host.engine.runtime.running()) for p, host in sim.hosts.items()}
        )
    return outcome


@pytest.fixture
def swarm(tmp_path: Path) -> Iterator[LocalSwarm]:
    with LocalSwarm(tmp_path, len(PLATFORMS)) as s:
        yield s


def test_ten_daemons_branch_and_merge_as_the_simulator_does(
    swarm: LocalSwarm, tmp_path: Path
) -> None:
    after_branch, after_merge = simulated()
    swarm.start_all()
    swarm.wait(
        "ten daemons that agree on a master",
        lambda: swarm.agreed_master() is not None and len(swarm.running()) == 10,
        timeout=40,
    )
    state = ["--state", str(tmp_path / "gs.json")]
    deployed = swarm.gs("deploy", str(SCRIPT), "--expect", "10", "--timeout", "20", *state)
    assert deployed.returncode == 0, deployed.stdout + deployed.stderr
    assert "confirmed by 10 of 10" in deployed.stdout
    started = swarm.gs("start", "--timeout", "20", *state)
    assert started.returncode == 0, started.stdout + started.stderr

    def actors() -> dict[str, str]:
        return {str(p): ",".join(swarm.status(p).get("actors", [])) for p in PLATFORMS}

    swarm.wait("ten A's", lambda: set(actors().values()) == {"A"})
    for event, expected in ((BRANCH, after_branch), (MERGE, after_merge)):
        fired = swarm.gs("event", event, "--timeout", "15")
        assert fired.returncode == 0, fired.stdout + fired.stderr
        # Which platforms become B depends on who asked first; how many does not.
        swarm.wait(
            f"the outcome of {event}: {Counter(expected.values())}",
            lambda expected=expected: Counter(actors().values()) == Counter(expected.values()),
            timeout=30,
            detail=lambda: str(Counter(actors().values())),
        )
    assert Counter(after_branch.values()) == {"B": 2, "C": 8}
    assert set(after_merge.values()) == {"A"}
    for p in PLATFORMS:
        hops = [(r["from"], r["to"], r["event"]) for r in swarm.status(p)["transitions"]]
        assert len(hops) == 3 and hops[0] == ("", "A", ""), (p, hops)
        src, mid, event = hops[1]
        assert (src, event) == ("A", BRANCH) and mid in {"B", "C"}, (p, hops)
        assert hops[2] == (mid, "A", MERGE), (p, hops)
    # Every branch of the release came from one barrier release: same time to within the
    # spread of one broadcast on loopback (generous: a loaded machine delays a process).
    switched = [swarm.status(p)["transitions"][1]["t"] for p in PLATFORMS]
    assert max(switched) - min(switched) < 2.0
