"""A deploy never blocks the daemon's loop: the script is checked by a child process while
the loop goes on serving. A real daemon runs in this process, next to a probe that wakes
every 5 ms; a ground station (``actorswarm gs deploy``, another process) deploys a script to
it over Zenoh on loopback (:func:`actorswarm.bench.deploy_stall.deploy_beside_probe`). How
long the loop stalls meanwhile depends on the machine's load: that is a benchmark figure
(``scripts/deploy_stall.py``); this test checks what does not."""

from __future__ import annotations

from pathlib import Path

from actorswarm.bench.deploy_stall import deploy_beside_probe

SCRIPT = Path(__file__).with_name("three.xml")


def test_the_loop_keeps_serving_while_a_deployed_script_is_checked(tmp_path: Path) -> None:
    run = deploy_beside_probe(SCRIPT, tmp_path / "state")
    assert run.code == 0, run.output
    assert "confirmed by 1 of 1" in run.output, run.output
    assert len(run.checks) == 1, "the deployed script was checked once"
    # A check made on the loop would hold it for the whole check (a child interpreter's
    # start-up at least): no wake-up of the probe could come inside the check's span, and
    # the loop's longest stall would be as long as the check.
    during = run.wakes_during_check()
    assert during >= 1 and run.worst < run.check_s, (
        f"{during} wake-ups of the loop's probe during a check of {run.check_s * 1000:.0f} ms; "
        f"the loop's longest stall {run.worst * 1000:.0f} ms"
    )
