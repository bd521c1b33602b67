"""A swarm beyond one radio's range: real daemons that reach only their neighbours.

Each platform and the ground station live in network namespaces of their own, joined by
veth pairs only where two of them are neighbours (:class:`netns_lab.Radios`): a chain of
five, and a 3 × 3 grid. Every link end delays what it sends by ``DELAY_MS`` and loses
``LOSS_PERCENT`` of it (``tc netem``), and no IP routing joins two links, so platform 1
and platform 5 of the chain never exchange a packet directly: the daemons relay
(``--relay``: Zenoh's router mode and its link-state routing).

The ground station is attached to the far end from platform 1, which is master (the lowest
ID): every command it sends crosses the whole swarm. In each topology the branch-and-merge
script (resized to the swarm) is deployed, started, branched and merged, each platform
switching exactly once per event on a barrier release; in the chain, the link between 2
and 3 then goes down (two swarms, masters 1 and 3) and up again (one swarm under 1); then
the master is killed and the survivors must agree on the next lowest ID, which the ground
station, from the other end, must hear. What each step took is printed (``-s`` shows it).
"""

from __future__ import annotations

import json
import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from netns_lab import PREFIX, Radios, impairment, reap_leftovers, run

from actorswarm.daemon.launch import LocalSwarm

ROOT = Path(__file__).resolve().parents[2]
BRANCH, MERGE = "AtoBC_branch_event", "finish_event"
PORT = 7447
LOSS_PERCENT = 2
DELAY_MS = 10


@pytest.fixture
def radios() -> Iterator[Radios]:
    prefix = f"{PREFIX}{os.getpid()}"
    kind = impairment(prefix)
    reap_leftovers()
    lab = Radios(prefix, kind, LOSS_PERCENT, DELAY_MS)
    try:
        yield lab
    finally:
        lab.teardown()


def _script(tmp_path: Path, size: int) -> Path:
    """examples/branch_merge.xml for ``size`` platforms: 2 to B, the rest to C."""
    text = (ROOT / "examples" / "branch_merge.xml").read_text()
    for old, new in (('sysNum="10"', f'sysNum="{size}"'), ('cnt="8"', f'cnt="{size - 2}"'),
                     ('sysNum="8"', f'sysNum="{size - 2}"')):  # fmt: skip
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"branch_merge_{size}.xml"
    path.write_text(text)
    return path


def _actors(swarm: LocalSwarm) -> dict[int, list[str]]:
    return {p: list(swarm.status(p).get("actors") or []) for p in swarm.running()}


def _gs(swarm: LocalSwarm, *args: str) -> str:
    done = swarm.gs(*args, timeout=60)
    assert done.returncode == 0, f"gs {' '.join(args)}: {done.stdout}{done.stderr}"
    return done.stdout


def _fly(
    radios: Radios, tmp_path: Path, size: int, gs_at: int, cut: tuple[int, int] | None = None
) -> str:
    """The whole scenario on the links ``radios`` holds; a line of what each step took.
    ``cut``: a link taken down after the merge and up again (two swarms, then one)."""
    radios.link(0, gs_at)
    # No IP route joins two links: the master's end cannot reach the ground station's.
    far = run("ip", "-n", radios.ns(1), "route", "get", radios.address(gs_at, 0))
    assert far.returncode != 0, f"platform 1 has a route to the far end: {far.stdout}"
    everyone = tuple(range(1, size + 1))
    links = radios.connects(everyone, PORT)
    with LocalSwarm(
        tmp_path / "swarm",
        size,
        endpoints=[f"tcp/0.0.0.0:{PORT}"] * size,
        links=links,
        gs_connect=[f"tcp/{radios.address(gs_at, 0)}:{PORT}"],
        wrap=radios.wrap,
        relay=True,
    ) as swarm:
        started = time.monotonic()
        steps: list[str] = []

        def mark(step: str) -> None:
            steps.append(f"{step} {time.monotonic() - started:.1f} s")

        swarm.start_all()
        swarm.wait(
            f"{size} daemons that agree on platform 1 as master",
            lambda: swarm.agreed_master(everyone) == 1,
            timeout=45,
            detail=lambda: f"masters {[swarm.status(p).get('master') for p in everyone]}",
        )
        assert all(swarm.events(p, "started")[-1]["relay"] is True for p in everyone)
        mark("master agreed")
        ids = f"1-{size}"
        state = ["--state", str(tmp_path / "gs.json")]
        script = _script(tmp_path, size)
        deployed = _gs(swarm, "deploy", str(script), "--expect", ids, "--timeout", "30", *state)
        assert f"confirmed by {size} of {size}" in deployed, deployed
        launched = _gs(swarm, "start", "--timeout", "30", *state)
        assert f"started on {size} of {size}" in launched, launched
        swarm.wait("every platform in A", lambda: all(a == ["A"] for a in _actors(swarm).values()),
                   detail=lambda: f"actors {_actors(swarm)}")  # fmt: skip
        mark("started")
        fired = _gs(swarm, "event", BRANCH, "--platforms", ids, "--timeout", "20")
        assert fired.count(f"event {BRANCH} delivered") == size, fired

        def branched() -> bool:
            actors = list(_actors(swarm).values())
            return actors.count(["B"]) == 2 and actors.count(["C"]) == size - 2

        swarm.wait("2 platforms in B, the rest in C", branched, timeout=30,
                   detail=lambda: f"actors {_actors(swarm)}")  # fmt: skip
        mark("branched")
        fired = _gs(swarm, "event", MERGE, "--platforms", ids, "--timeout", "20")
        assert fired.count(f"event {MERGE} delivered") == size, fired
        swarm.wait("all back in A", lambda: all(a == ["A"] for a in _actors(swarm).values()),
                   timeout=30, detail=lambda: f"actors {_actors(swarm)}")  # fmt: skip
        mark("merged")
        time.sleep(1.0)  # a late release must not switch a platform twice
        for p in everyone:
            rows: list[dict[str, Any]] = swarm.status(p).get("transitions") or []
            got = [(r["from"], r["to"], r["event"], r["cause"]) for r in rows]
            to = got[1][1] if len(got) > 1 else "?"
            assert to in ("B", "C") and got == [
                ("", "A", "", "start"), ("A", to, BRANCH, "barrier"), (to, "A", MERGE, "barrier")
            ], f"platform {p}: transitions {got}"  # fmt: skip

        if cut is not None:
            # Out of range in the middle: each side agrees on its own lowest ID, then the
            # healed chain on platform 1 again.
            radios.set_link(*cut, up=False)
            near, far = everyone[: cut[0]], everyone[cut[0] :]
            swarm.wait(
                f"two swarms, masters 1 and {far[0]}",
                lambda: swarm.agreed_master(near) == 1 and swarm.agreed_master(far) == far[0],
                timeout=20,
                detail=lambda: f"masters {[swarm.status(p).get('master') for p in everyone]}",
            )
            mark("split")
            radios.set_link(*cut, up=True)
            swarm.wait(
                "one swarm again under platform 1",
                lambda: swarm.agreed_master(everyone) == 1,
                timeout=45,
                detail=lambda: f"masters {[swarm.status(p).get('master') for p in everyone]}",
            )
            mark("healed")

        # The master, at the far end from the ground station, dies.
        killed = time.monotonic()
        swarm.stop(1, signal.SIGKILL)
        survivors = everyone[1:]
        took = swarm.wait(
            "the survivors agree on platform 2",
            lambda: swarm.agreed_master(survivors) == 2,
            timeout=20,
            detail=lambda: f"masters {[swarm.status(p).get('master') for p in survivors]}",
        )
        follows = [
            line["t"] - killed
            for p in survivors
            for line in swarm.events(p, "master")
            if line.get("master") == 2 and line["t"] > killed
        ]
        mark(f"new master (all follow {max(follows):.2f} s after the kill; seen {took:.1f})")
        heard = json.loads(_gs(swarm, "status", "--json", "--timeout", "5"))
        assert {int(p) for p in heard["platforms"]} == set(survivors), heard
        assert [p for p, row in heard["platforms"].items() if row["master"]] == ["2"], heard
    lost, offered = radios.drops()
    assert offered > 1000 and lost > 0, (lost, offered)
    return f"{', '.join(steps)}; {lost} of {offered} packets sent on the links were lost"


def test_a_chain_of_five_stays_one_swarm(radios: Radios, tmp_path: Path) -> None:
    """1 — 2 — 3 — 4 — 5 — ground station: four hops from the master to the far end. The
    chain is also broken between 2 and 3 for a while: two swarms, merged again."""
    for p in range(1, 5):
        radios.link(p, p + 1)
    line = _fly(radios, tmp_path, 5, gs_at=5, cut=(2, 3))
    print(f"\nchain of 5, {radios.describe()}: {line}")


def test_a_three_by_three_grid_stays_one_swarm(radios: Radios, tmp_path: Path) -> None:
    """Platforms 1..9 row by row, each linked to the one beside and the one below; the
    ground station at 9, four hops from the master (1) in the opposite corner."""
    for p in range(1, 10):
        row, col = divmod(p - 1, 3)
        if col < 2:
            radios.link(p, p + 1)
        if row < 2:
            radios.link(p, p + 3)
    print(f"\n3x3 grid, {radios.describe()}: {_fly(radios, tmp_path, 9, gs_at=9)}")
