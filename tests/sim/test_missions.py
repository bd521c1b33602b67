"""The shipped missions (issue: the paper's two missions and a reorganization) run to the
end, under many seeds, with radio loss and with a platform killed, and hold their shapes.

Each run is a whole simulated mission (seconds of wall time each), so the runs are shared
through module-scoped fixtures and the assertions are spread over several tests. A failing
run prints how to replay it with ``actorswarm demo``.
"""

from __future__ import annotations

import json
import math
import os
import re
import shlex
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from actorswarm.dsl import check_file
from actorswarm.engine.engine import TaskEngine
from actorswarm.missions import MISSIONS, Mission, mission
from actorswarm.plugins.formation import Formation
from actorswarm.plugins.tracking import TrackTarget
from actorswarm.sim.mission import prepare, run_slices
from actorswarm.sim.tasksim import Fault, TaskSim
from actorswarm.sim.vehicle_faults import VehicleFault
from actorswarm.world.separation import BREACH_PREFIX

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: The least 3-D distance between two airborne fixed-wings the formation runs below keep,
#: metres: their world's separation. docs/safety.md gives the figures.
SAFETY_DISTANCE = 10.0
#: The quadrotors' separation, which the search-and-track runs keep (by far: 9.99 m).
QUADROTOR_DISTANCE = 3.0
#: Under 10 % loss a member that switches late can still cut through a neighbour's altitude
#: while climbing to its transit layer in a change of shape: 9.56 m (seed 4) and 9.32 m
#: (seed 1) at 93 s, just after B branches into C. The way home keeps SAFETY_DISTANCE.
LOSSY_DISTANCE = 9.0
#: Seeds of the "under other seeds" runs: 1-2 in every run of the suite for search and
#: track, 1 for the formation (each formation run of 30 is 25-40 s of CPU and the suite
#: must stay under 15 minutes on two cores; its seeds 0, 4 and 5 run in the tests below,
#: and the missions under seeded faults are `task verify`'s,
#: tests/sim/test_verify_examples.py); set ACTORSWARM_MISSION_SEEDS=10 (or more) for the
#: long sweep before a release.
SEEDS = range(1, 1 + int(os.environ.get("ACTORSWARM_MISSION_SEEDS", "2")))
FORMATION_SEEDS = SEEDS if "ACTORSWARM_MISSION_SEEDS" in os.environ else range(1, 2)


class Run:
    """One simulated mission and what the tests look at."""

    def __init__(
        self,
        name: str,
        *,
        seed: int = 0,
        loss: float = 0.0,
        platforms: int | None = None,
        kills: tuple[tuple[int, float], ...] = (),
        probe_shapes: bool = False,
        refuse: frozenset[int] = frozenset(),
    ) -> None:
        self.mission: Mission = mission(name)
        self.replay = (
            f"actorswarm demo --mission {name} --seed {seed}"
            + (f" --loss {loss}" if loss else "")
            + (f" --platforms {platforms}" if platforms else "")
            + "".join(f" --kill {p}@{t:g}" for p, t in kills)
        )
        if refuse:  # the same run from the sim command (demo has no vehicle faults)
            m = self.mission
            self.replay = (
                f"actorswarm sim {m.script_path} --world {m.world_path} --duration {m.duration:g}"
                + "".join(f" --event {name}@{t:g}" for name, t in m.events)
                + f" --seed {seed} --refuse-takeoff {','.join(map(str, sorted(refuse)))}"
            )
        faults = (VehicleFault("refuse", refuse),) if refuse else ()
        self.sim: TaskSim = prepare(
            self.mission,
            platforms=platforms,
            seed=seed,
            loss=loss,
            kills=kills,
            vehicle_faults=faults,
        )
        #: Per phase end (just before each ground-station event): actor → the members'
        #: offsets from their slots, (n, 2).
        self.shapes: list[tuple[float, dict[str, np.ndarray]]] = []
        probes = [t - 0.5 for _, t in self.mission.events] if probe_shapes else []
        self.report: dict[str, Any] = run_slices(
            self.sim,
            self.mission.duration,
            slice_s=0.5,
            on_slice=lambda t, _new: (
                self._probe(t) if any(abs(t - p) < 1e-6 for p in probes) else None
            ),
        )

    def _probe(self, t: float) -> None:
        world = self.sim.world
        assert world is not None
        offsets: dict[str, list[np.ndarray]] = {}
        for platform, host in self.sim.hosts.items():
            runtime = host.engine.runtime
            for actor in runtime.running():
                for plugin in runtime.plugins(actor):
                    if isinstance(plugin, Formation):
                        here = np.array(world.vehicle(platform).position()[:2])
                        slot = np.array(plugin.slot_point(self.sim.swarm.now)[:2])
                        offsets.setdefault(actor, []).append(here - slot)
        self.shapes.append((t, {a: np.array(v) for a, v in offsets.items()}))

    def moves(self) -> Counter[tuple[str, str, str]]:
        return Counter(
            (t["from"], t["to"], t["event"])
            for t in self.report["transitions"]
            if t["cause"] not in ("start", "lost")
        )

    def clean(self, *, separation: bool = True) -> None:
        """Completed, every invariant held, no plugin failed; and, with ``separation``,
        no separation breach either (without: breaches are left to the caller)."""
        r = self.report
        how = f"replay: {self.replay}"
        assert r["completed"], f"not completed, final actors {r['final_actors']}; {how}"
        violations = r["violations"]
        if not separation:
            violations = [v for v in violations if not v.startswith(BREACH_PREFIX)]
        assert violations == [], f"{violations}; {how}"
        assert r["plugin_failures"] == [], f"{r['plugin_failures']}; {how}"

    def breaches_from(self, t: float) -> list[dict[str, Any]]:
        """The separation breaches that were still going on at or after ``t`` seconds."""
        return [b for b in self.report["separation"]["breaches"] if b["end"] >= t]

    def least_separation(self) -> float:
        """The least 3-D distance between two airborne vehicles in the run (the report's
        separation, measured every physics step)."""
        least = self.report["separation"]["min_distance_m"]
        assert least is not None
        return float(least)


@pytest.fixture(scope="module")
def formation() -> Run:
    return Run("formation", probe_shapes=True)


@pytest.fixture(scope="module")
def search_track() -> Run:
    return Run("search-track")


@pytest.fixture(scope="module")
def battery() -> Run:
    return Run("battery")


# --- the catalogue ---------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(MISSIONS))
def test_each_mission_s_files_are_valid_and_shipped_as_examples(name: str) -> None:
    m = MISSIONS[name]
    assert check_file(m.script_path).script is not None
    assert (EXAMPLES / m.script).resolve() == m.script_path.resolve()
    assert (EXAMPLES / "worlds" / m.world).resolve() == m.world_path.resolve()


@pytest.mark.parametrize("name", ["formation", "search-track"])
def test_the_script_s_sim_line_runs_the_same_mission(name: str) -> None:
    """The ``<?actorswarm sim ...?>`` line of the script is the demo's mission."""
    m = MISSIONS[name]
    line = re.search(r"<\?actorswarm sim (.*?)\?>", m.script_path.read_text())
    assert line is not None
    args = shlex.split(line.group(1))
    assert args[0] == f"examples/{m.script}"
    assert args[1:] == m.sim_arguments()


def test_an_unknown_mission_is_refused_with_a_suggestion() -> None:
    with pytest.raises(KeyError, match='did you mean "formation"'):
        mission("formaton")


# --- the formation mission ---------------------------------------------------------------


def test_formation_runs_every_phase_of_the_paper(formation: Run) -> None:
    formation.clean(separation=False)
    assert formation.moves() == {
        ("Standby", "A", "ready_event"): 30,
        ("A", "B", "AtoB_event"): 30,
        ("B", "C", "BtoBC_branching_event"): 15,
        ("B", "D", "BCtoD_event"): 15,
        ("C", "D", "BCtoD_event"): 15,
        ("D", "E", "DtoE_event"): 30,
        ("E", "A", "EtoA_event"): 30,
        ("A", "Return", "go_home_event"): 30,
    }
    by_event: dict[str, list[float]] = {}
    for t in formation.report["transitions"]:
        if t["event"] != "ready_event" and t["cause"] == "barrier":
            by_event.setdefault(t["event"], []).append(t["t"])
    for event, at in dict(formation.mission.events).items():
        times = by_event[event]
        assert at <= min(times) and max(times) - at < 0.1, f"{event}: switched at {times}"


def test_formation_members_converge_to_their_shapes(formation: Run) -> None:
    """Just before each event, the members are on their shape: after removing the swarm's
    common lag behind its leader, the median member is within 35 m of its slot (slots are
    40 m apart) and most are within 60 m; the common lag is under 45 m."""
    assert len(formation.shapes) == len(formation.mission.events)
    for t, by_actor in formation.shapes:
        for actor, offsets in by_actor.items():
            lag = offsets.mean(axis=0)
            error = np.linalg.norm(offsets - lag, axis=1)
            where = f"{actor} at {t:.1f} s: errors {np.round(error).tolist()}"
            assert float(np.hypot(*lag)) < 45.0, where
            assert float(np.median(error)) < 35.0, where
            assert float(np.mean(error < 60.0)) >= 0.7, where


def test_formation_keeps_airborne_vehicles_apart(formation: Run) -> None:
    """The 10 m separation holds at every instant, the way home included: no breach, none
    in the report's violations."""
    assert formation.least_separation() >= SAFETY_DISTANCE
    assert formation.report["separation"]["breaches"] == []
    assert not [v for v in formation.report["violations"] if v.startswith(BREACH_PREFIX)]


def test_formation_slots_are_the_master_s_least_distance_assignment(formation: Run) -> None:
    """Every member of the merged group D has its own slot, numbered over both parts."""
    slots = sorted(h.engine.runtime.acbs()["D"].context.slot for h in formation.sim.hosts.values())
    assert slots == list(range(1, 31))


@pytest.mark.parametrize("seed", FORMATION_SEEDS)
def test_formation_completes_under_other_seeds(seed: int) -> None:
    run = Run("formation", seed=seed)
    run.clean(separation=False)
    moves = run.moves()
    assert moves[("A", "B", "AtoB_event")] == 30
    assert moves[("B", "C", "BtoBC_branching_event")] == 15
    assert moves[("A", "Return", "go_home_event")] == 30
    assert run.least_separation() >= SAFETY_DISTANCE


def test_formation_scales_to_another_swarm_size_and_flies_on_without_a_killed_member() -> None:
    """``--platforms 15``: the branch of 15 of 30 becomes 8 of 15; platform 7, killed at
    100 s (after the branch), is left out of every later shape and the others fly home."""
    run = Run("formation", seed=5, platforms=15, kills=((7, 100.0),))
    run.clean(separation=False)
    moves = run.moves()
    assert moves[("A", "B", "AtoB_event")] == 15
    assert moves[("B", "C", "BtoBC_branching_event")] == 8
    assert "7" not in run.report["final_actors"]
    assert moves[("A", "Return", "go_home_event")] == 14
    assert run.least_separation() >= SAFETY_DISTANCE


def test_formation_completes_with_ten_percent_loss() -> None:
    run = Run("formation", seed=4, loss=0.1)
    run.clean(separation=False)
    assert run.moves()[("A", "Return", "go_home_event")] == 30
    assert run.least_separation() >= LOSSY_DISTANCE
    assert run.breaches_from(dict(run.mission.events)["go_home_event"]) == []


# --- search and track --------------------------------------------------------------------


def _trackers(run: Run) -> list[dict[str, Any]]:
    return [t for t in run.report["transitions"] if t["to"] == "Track"]


def test_search_track_finds_and_follows_the_jeep(search_track: Run) -> None:
    search_track.clean()
    moves = search_track.moves()
    assert moves[("Standby", "Ingress", "ready_event")] == 10
    assert moves[("Ingress", "Range", "arriving_event")] == 10
    trackers = _trackers(search_track)
    assert len(trackers) == 1, f"exactly one tracker: {trackers}"
    tracker, since = trackers[0]["platform"], trackers[0]["t"]
    assert since < 200.0
    # The tracker keeps over the jeep: at go_home it is within 10 m of it (horizontally).
    world = search_track.sim.world
    assert world is not None
    track = world.track()
    i = int(np.searchsorted(track.times, 199.5))
    over = track.positions[i, list(track.platforms).index(tracker), :2]
    jeep = track.target_positions[i, 0, :2]
    assert math.dist(over.tolist(), jeep.tolist()) < 10.0
    assert search_track.least_separation() >= QUADROTOR_DISTANCE


@pytest.mark.parametrize("seed", SEEDS)
def test_search_track_completes_under_other_seeds(seed: int) -> None:
    run = Run("search-track", seed=seed)
    run.clean()
    assert len(_trackers(run)) == 1


def test_search_track_completes_with_ten_percent_loss() -> None:
    run = Run("search-track", seed=3, loss=0.1)
    run.clean()
    assert len(_trackers(run)) == 1


def test_search_track_completes_with_a_searcher_killed() -> None:
    run = Run("search-track", seed=2, kills=((9, 80.0),))
    run.clean()
    assert "9" not in run.report["final_actors"]
    assert len(run.report["final_actors"]) == 9


def test_search_track_flies_on_without_a_quadrotor_that_never_arms_and_completes() -> None:
    """Platform 10's autopilot never lets it take off: the take-off gives up 120 s after it
    was asked and raises vehicle_fault_event, which the script answers with Grounded (on
    the ground, out of the mission); the nine others fly the mission, and the run completes
    (before the Grounded actor, platform 10 stayed in Standby and it never did)."""
    run = Run("search-track", seed=4, refuse=frozenset({10}))
    run.clean()
    assert run.report["final_actors"]["10"] == ["Grounded"]
    grounded = [t for t in run.report["transitions"] if t["to"] == "Grounded"]
    assert [(t["platform"], t["from"], t["event"]) for t in grounded] == [
        (10, "Standby", "vehicle_fault_event")
    ]
    assert 119.0 <= grounded[0]["t"] <= 125.0, grounded
    finals = Counter(a for actors in run.report["final_actors"].values() for a in actors)
    assert finals == {"Return": 9, "Grounded": 1}


# --- reorganization ------------------------------------------------------------------------


class TrackerDown:
    """The search-track mission, the tracker taken away 2 s after it starts tracking —
    crashed (``kill``) or cut off for 5 s (``partition``, then healed: a false loss) — and
    run to 175 s, past the moment another searcher's camera sees the jeep (about 170 s)."""

    DURATION = 175.0

    def __init__(self, seed: int, how: str) -> None:
        self.sim = prepare(mission("search-track"), seed=seed)
        self.tracker: int | None = None
        self.down_at: float | None = None
        #: Platform -> horizontal distance to the tracker when it went down (the others).
        self.distances: dict[int, float] = {}
        heal_at: float | None = None

        def on_slice(t: float, new: list[dict[str, Any]]) -> None:
            nonlocal heal_at
            world = self.sim.world
            assert world is not None
            if self.tracker is None:
                first = [r for r in new if r["to"] == "Track"]
                if first:
                    self.tracker, self.down_at = first[0]["platform"], t + 2.0
            elif self.down_at is not None and t == self.down_at:
                down = world.vehicle(self.tracker).position()
                for p in self.sim.hosts:
                    if p != self.tracker:
                        here = world.vehicle(p).position()
                        self.distances[p] = math.dist(down[:2], here[:2])
                ids = frozenset({self.tracker})
                self.sim.fault(Fault("kill" if how == "kill" else "partition", t, ids))
                heal_at = t + 5.0 if how == "partition" else None
            elif heal_at is not None and t == heal_at:
                self.sim.fault(Fault("heal", t))

        self.report = run_slices(self.sim, self.DURATION, slice_s=0.5, on_slice=on_slice)

    def holders(self, actor: str) -> list[int]:
        return sorted(int(p) for p, a in self.report["final_actors"].items() if actor in a)

    def master_engine(self) -> TaskEngine:
        (engine,) = [h.engine for h in self.sim.hosts.values() if h.engine.node.is_master]
        return engine


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_crashed_tracker_is_replaced_by_the_nearest_searcher_and_stays_one(seed: int) -> None:
    run = TrackerDown(seed, "kill")
    assert run.report["violations"] == [] and run.report["plugin_failures"] == []
    assert run.tracker is not None and run.down_at is not None
    promoted = [t for t in run.report["transitions"] if t["event"] == "Track_lost"]
    assert len(promoted) == 1, promoted
    nearest = min(run.distances, key=run.distances.__getitem__)
    assert promoted[0]["platform"] == nearest, f"promoted {promoted}, distances {run.distances}"
    assert run.down_at < promoted[0]["t"] < run.down_at + 2.0
    # A searcher that saw the jeep afterwards was refused the role: one tracker at the end,
    # holding the role.
    later = [t for t in run.report["transitions"] if t["to"] == "Track" and t["t"] > run.down_at]
    assert later == promoted, later
    assert run.holders("Track") == [nearest]
    assert run.master_engine().node.role_holders("track:jeep") == (nearest,)
    # It looked where the lost tracker was, found the jeep and follows it.
    (follow,) = [
        p
        for p in run.sim.hosts[nearest].engine.runtime.plugins("Track")
        if isinstance(p, TrackTarget)
    ]
    assert follow.last is not None and not follow.lost


def test_a_tracker_falsely_taken_for_lost_leaves_one_tracker_when_it_is_back() -> None:
    run = TrackerDown(1, "partition")
    assert run.report["violations"] == [] and run.report["plugin_failures"] == []
    assert run.tracker is not None
    promoted = [t["platform"] for t in run.report["transitions"] if t["event"] == "Track_lost"]
    assert len(promoted) == 1 and promoted[0] != run.tracker
    # Back from the partition both hold the role; the master keeps the better bid — the
    # tracker that had the jeep in view, not the promoted one still looking for it — and
    # the other yields and goes back to searching.
    yielded = [t for t in run.report["transitions"] if t["event"] == "track_yield_event"]
    assert [(t["platform"], t["from"], t["to"]) for t in yielded] == [
        (promoted[0], "Track", "Range")
    ]
    assert run.holders("Track") == [run.tracker]
    assert run.master_engine().node.role_holders("track:jeep") == (run.tracker,)


def test_a_tracker_whose_battery_dies_is_replaced_by_track_lost(battery: Run) -> None:
    battery.clean()
    assert [w["platform"] for w in battery.report["wrecks"]] == [2]
    died = battery.report["wrecks"][0]["t"]
    trackers = _trackers(battery)
    first = trackers[0]
    assert (first["platform"], first["event"]) == (2, "target_detected_event")
    promoted = [t for t in trackers if t["event"] == "Track_lost"]
    assert len(promoted) == 1, f"one promotion: {trackers}"
    assert died < promoted[0]["t"] < died + 2.0
    assert "2" not in battery.report["final_actors"]
    lost = [t for t in battery.report["transitions"] if t["cause"] == "lost"]
    assert [(t["platform"], t["from"], t["t"]) for t in lost] == [(2, "Track", died)]
    # No searcher became a second tracker, and the promoted one (the nearest: platform 3,
    # on the next lane) looked where platform 2 fell and is over the jeep at go_home.
    detected = [t for t in trackers if t["event"] == "target_detected_event"]
    assert len(detected) == 1
    assert promoted[0]["platform"] == 3
    world = battery.sim.world
    assert world is not None
    track = world.track()
    i = int(np.searchsorted(track.times, 199.5))
    over = track.positions[i, list(track.platforms).index(3), :2]
    jeep = track.target_positions[i, 0, :2]
    assert math.dist(over.tolist(), jeep.tolist()) < 10.0


def test_formation_late_take_off_holds_under_the_others(tmp_path: Path) -> None:
    """An autopilot ready 51 s late (verify's replay, seed 1000): without ``late_after`` the
    aircraft climbs out through the circles of those ahead of it on its row (5.8 m and
    2.2 m at 72-74 s). It holds 20 m under them instead, and the join keeps the 10 m."""
    from typer.testing import CliRunner

    from actorswarm.cli.app import app

    out = tmp_path / "late.json"
    args = ["sim", str(EXAMPLES / "formation_30.xml"), "--world",
            str(EXAMPLES / "worlds" / "formation_30.toml"), "--duration", "80", "--seed", "1000",
            "--late-ready", "16@51.4", "--json", str(out)]  # fmt: skip
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())
    moves = [(t["from"], t["to"], t["cause"]) for t in report["transitions"] if t["to"] == "A"]
    assert moves == [("Standby", "A", "barrier")] * 30
    assert report["separation"]["breaches"] == []
    assert report["separation"]["min_distance_m"] >= SAFETY_DISTANCE
