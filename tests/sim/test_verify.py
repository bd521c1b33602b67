"""``actorswarm task verify``: profiles, schedules, delta debugging, the runs, the report,
and bad input (issue: a user's mission under thousands of seeded faults).

The runs here are of the branch-and-merge script without vehicles (about half a second
each) and, for the autopilot faults, of a short take-off script in the default world.
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.sim.tasksim import GroundEvent, TaskSim, parse_event, parse_fault
from actorswarm.sim.vehicle_faults import REFUSE_AFTER_S, VehicleFault, parse_vehicle_fault
from actorswarm.sim.verify.minimize import ddmin
from actorswarm.sim.verify.pool import Pool
from actorswarm.sim.verify.profile import (
    DEFAULT_PROFILE,
    FaultProfile,
    KillFaults,
    ProfileError,
    RadioFaults,
    load_profile,
    profile_from_dict,
)
from actorswarm.sim.verify.runner import Mission, run_one
from actorswarm.sim.verify.schedule import Schedule, draw
from actorswarm.sim.verify.session import schedules, verify, wilson

ROOT = Path(__file__).resolve().parents[2]
BRANCH = ROOT / "examples" / "branch_merge.xml"
TAKEOFF = ROOT / "examples" / "takeoff_ingress_return.xml"
EVENTS = (GroundEvent("AtoBC_branch_event", 5.0), GroundEvent("finish_event", 10.0))

#: Only crashes (no radio trouble, no moved event): every failure is a kill's doing.
KILLS_ONLY = FaultProfile(
    radio=RadioFaults(loss=(0.0, 0.0), latency_ms=(10.0, 10.0), jitter_ms=(0.0, 0.0)),
    kills=KillFaults(rate=2.0, master=0.0, after_event=1.0, after_event_s=(0.2, 1.0), restart=0.0),
    partitions=DEFAULT_PROFILE.partitions.__class__(rate=0.0),
    events=DEFAULT_PROFILE.events.__class__(shift=0.0),
)


def branch_mission(**kw: object) -> Mission:
    args: dict[str, object] = {
        "script_text": BRANCH.read_text(),
        "script_path": str(BRANCH),
        "world_text": None,
        "world_path": None,
        "duration": 16.0,
        "events": EVENTS,
        "no_world": True,
        "done": ("A",),
        "came_back": ("A",),
    }
    args.update(kw)
    return Mission(**args)  # type: ignore[arg-type]


def cli(*args: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, list(args))
    return result.exit_code, result.stdout, result.stderr


# --- profiles -------------------------------------------------------------------------------


def test_profile_file_overrides_the_default_and_names_the_line_of_a_mistake(
    tmp_path: Path,
) -> None:
    good = tmp_path / "p.toml"
    good.write_text("[radio]\nloss = [0.05, 0.05]\n\n[kills]\nrate = 0\n")
    profile = load_profile(good)
    assert profile.radio.loss == (0.05, 0.05)
    assert profile.kills.rate == 0.0
    assert profile.partitions == DEFAULT_PROFILE.partitions  # untouched tables: the default

    typo = tmp_path / "typo.toml"
    typo.write_text("[radio]\nloss = [0, 0.1]\n\n[kills]\nrat = 2\n")
    with pytest.raises(ProfileError) as err:
        load_profile(typo)
    assert f"{typo}:5: [kills] rat: unknown key (did you mean" in str(err.value)

    for text, said in (
        ("[radio]\nloss = [0, 1.5]\n", ":2: [radio] loss: must lie within [0, 0.9]"),
        ("[kills]\nmaster = 2\n", ":2: [kills] master: must be a probability within 0..1"),
        ("[partitions]\nheal_after_s = [9, 3]\n", "low end 9 is above its high end 3"),
        ("[vehicle]\nlate = 0.1\n", ":1: unknown table [vehicle] (did you mean"),
        ("[radio]\nloss = 'much'\n", "must be a range [low, high] of two numbers"),
    ):
        bad = tmp_path / "bad.toml"
        bad.write_text(text)
        with pytest.raises(ProfileError, match=r".*") as err:
            load_profile(bad)
        assert said in str(err.value), (text, str(err.value))


def test_a_kill_of_a_platform_the_script_lacks_is_named_at_its_line() -> None:
    text = "[kills]\nplatforms = '1-3,99'\n"
    profile = profile_from_dict({"kills": {"platforms": "1-3,99"}}, source="p.toml", text=text)
    problems = profile.problems(frozenset(range(1, 11)))
    assert problems == [
        "p.toml:2: [kills] platforms: the script starts no platform 99 (its platforms: 1-10)"
    ]
    assert profile.problems(frozenset(range(1, 100))) == []


# --- schedules ------------------------------------------------------------------------------


def test_a_schedule_is_its_seed_and_its_options_are_the_same_faults() -> None:
    platforms = list(range(1, 11))
    a = draw(DEFAULT_PROFILE, 7, platforms, 60.0, EVENTS, vehicles=True)
    assert a == draw(DEFAULT_PROFILE, 7, platforms, 60.0, EVENTS, vehicles=True)
    drawn = [draw(DEFAULT_PROFILE, s, platforms, 60.0, EVENTS, vehicles=True) for s in range(40)]
    assert len({d.items for d in drawn}) > 30  # seeds differ
    kinds = {i.kind for d in drawn for i in d.items}
    assert kinds == {"loss", "delay", "kill", "partition", "vehicle", "shift"}
    # Parsed back as `sim` parses its command line, the options are the same schedule.
    for schedule in drawn:
        words = schedule.sim_options()
        faults, vehicles, events = [], [], []
        for flag, value in zip(words[::2], words[1::2], strict=True):
            name = flag.removeprefix("--")
            if name in ("kill", "restart", "partition", "heal"):
                faults.append(parse_fault(name, value))
            elif name == "event":
                events.append(parse_event(value))
            elif name in ("late-ready", "refuse-takeoff", "drain"):
                kind = {"late-ready": "late", "refuse-takeoff": "refuse", "drain": "drain"}[name]
                vehicles.append(parse_vehicle_fault(kind, value))  # type: ignore[arg-type]
        assert faults == schedule.faults()
        assert tuple(vehicles) == schedule.vehicle_faults()
        assert events == schedule.ground_events()


def test_no_faults_are_drawn_after_the_run_or_of_vehicles_without_a_world() -> None:
    for seed in range(50):
        s = draw(DEFAULT_PROFILE, seed, list(range(1, 31)), 100.0, EVENTS, vehicles=False)
        assert not s.vehicle_faults()
        assert all(0 <= f.t <= 100.0 for f in s.faults())
        assert all(0 <= e.t <= 100.0 for e in s.ground_events())


# --- delta debugging ------------------------------------------------------------------------


def test_ddmin_finds_the_faults_a_failure_needs() -> None:
    assert ddmin(list(range(10)), lambda s: 3 in s and 7 in s) == ([3, 7], 21, True)
    assert ddmin(list(range(10)), lambda s: True)[0] == []  # fails with no fault at all
    kept, tests, complete = ddmin(list(range(30)), lambda s: {1, 9, 28} <= set(s), budget=5)
    assert tests == 5 and not complete and {1, 9, 28} <= set(kept)


def test_wilson_interval() -> None:
    assert wilson(0, 0) == (0.0, 1.0)
    low, high = wilson(95, 100)
    assert low == pytest.approx(0.8882, abs=1e-3) and high == pytest.approx(0.9785, abs=1e-3)
    assert wilson(10, 10)[1] == 1.0 and wilson(0, 10)[0] == 0.0


# --- autopilot faults and the master as a target in the simulator ---------------------------


def takeoff_run(*faults: VehicleFault, duration: float = 40.0) -> TaskSim:
    from actorswarm.dsl import check_file
    from actorswarm.world.config import load_world

    script = check_file(TAKEOFF).script
    assert script is not None
    run = TaskSim(
        script, world_config=load_world(ROOT / "examples/worlds/default.toml"),
        vehicle_faults=faults,
    )  # fmt: skip
    run.run(duration)
    return run


def test_a_late_autopilot_takes_off_when_ready_and_a_refusing_one_raises_its_fault() -> None:
    clean = takeoff_run()
    late = takeoff_run(VehicleFault("late", frozenset({2}), 20.0), duration=19.5)
    assert clean.world is not None and late.world is not None
    assert clean.world.vehicle(2).position()[2] > 5.0  # up by 19.5 s without the fault
    assert late.world.vehicle(2).position()[2] == 0.0  # still on the ground
    assert late.world.vehicle(3).position()[2] > 5.0  # the others fly
    later = takeoff_run(VehicleFault("late", frozenset({2}), 20.0), duration=40.0)
    assert later.world is not None and later.world.vehicle(2).position()[2] > 5.0

    refused = takeoff_run(VehicleFault("refuse", frozenset({1})), duration=REFUSE_AFTER_S + 5)
    report = refused.report()
    assert refused.world is not None and refused.world.vehicle(1).position()[2] == 0.0
    # The script answers the fault: that platform alone goes to Grounded, on the ground.
    raised = [t for t in report["transitions"] if t["event"] == "vehicle_fault_event"]
    assert [(t["platform"], t["from"], t["to"]) for t in raised] == [(1, "Standby", "Grounded")]
    assert raised[0]["t"] == pytest.approx(REFUSE_AFTER_S, abs=1.0)


def test_a_draining_battery_empties_sooner() -> None:
    clean = takeoff_run(duration=60.0)
    drained = takeoff_run(VehicleFault("drain", frozenset({1}), 5.0), duration=60.0)
    assert clean.world is not None and drained.world is not None
    used_clean = 1.0 - clean.world.vehicle(1).battery()
    used_drained = 1.0 - drained.world.vehicle(1).battery()
    assert used_clean > 0 and used_drained == pytest.approx(5 * used_clean, rel=0.05)


def test_sim_kills_and_restarts_whoever_is_master() -> None:
    code, out, _ = cli(
        "sim", str(BRANCH), "--no-world", "--duration", "12", "--kill", "master@3",
        "--restart", "master@6", "--json", "-",
    )  # fmt: skip
    report = json.loads(out)
    first = report["masters"][0]["platform"]
    lost = [t for t in report["transitions"] if t["cause"] == "lost"]
    assert [t["platform"] for t in lost] == [first]
    assert len(report["masters"]) >= 2  # another took over
    assert report["final_actors"][str(first)] == ["A"]  # rebooted, running again
    assert code == 0


# --- the runs -------------------------------------------------------------------------------


def test_an_exact_group_without_timeout_stalls_when_one_of_it_dies_and_is_minimized_to_it(
) -> None:  # fmt: skip
    mission = branch_mission()
    planned = schedules(mission, KILLS_ONLY, 100, 8, list(range(1, 11)))
    outcome = verify(mission, KILLS_ONLY, planned, Pool(workers=1), budget=24)
    assert len(outcome.results) == 8
    stuck = [c for c in outcome.classes if c.signature.startswith("stuck:")]
    assert stuck, [r.signature for r in outcome.results]
    cls = stuck[0]
    assert cls.minimized is not None and cls.minimized.complete
    assert cls.minimized.result.signature == cls.signature
    # One crash is enough to stall the merge (sysNum exact, no timeout).
    assert [i.kind for i in cls.minimized.schedule.items] == ["kill"]
    assert cls.minimized.original >= 1
    # The replay command, run as a user would, fails the same way.
    args = shlex.split(cls.replay)[1:]
    _, out, _ = cli(*args, "--json", "-")
    report = json.loads(out)
    assert report["final_actors"] != {str(p): ["A"] for p in range(1, 11)}
    assert sorted(report["waiting"]) == sorted(
        a for a in cls.minimized.result.why.split() if a in ("B", "C")
    )


def test_a_run_replays_bit_for_bit_and_the_clean_radio_completes() -> None:
    mission = branch_mission()
    schedule = draw(DEFAULT_PROFILE, 3, list(range(1, 11)), 16.0, EVENTS, vehicles=False)
    a, b = run_one(mission, schedule), run_one(mission, schedule)
    assert (a.as_dict() | {"wall_s": 0}) == (b.as_dict() | {"wall_s": 0})
    clean = run_one(mission, Schedule(0, EVENTS))
    assert clean.ok and clean.completed and clean.completion_s == pytest.approx(10.02, abs=0.1)
    assert clean.packets > 1000 and clean.master_changes == 1


def test_a_looping_mission_is_done_only_once_its_platforms_came_back() -> None:
    """``--done A`` of a script that starts in A: a run whose platforms never left A (here
    the operator never branched) is not taken for one that went round and came back."""
    idle = run_one(branch_mission(events=()), Schedule(0, ()))
    assert not idle.completed and idle.completion_s is None
    assert idle.why == "A on 10 waits for AtoBC_branch_event"
    assert run_one(branch_mission(events=(), came_back=()), Schedule(0, ())).completed
    code, stdout, _ = cli(
        "task", "verify", str(BRANCH), "--runs", "1", "--workers", "1", "--done", "A",
        "--event", "finish_event@10", "--json", "-",
    )  # fmt: skip
    data = json.loads(stdout)
    (result,) = data["results"]
    assert code == 0 and not result["completed"], result
    assert result["signature"] == "stuck: A on # waits for AtoBC_branch_event"


def test_a_crash_of_the_simulator_is_its_own_class_and_the_others_run_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    real = TaskSim.run

    def crashing(self: TaskSim, duration: float, **kw: object) -> dict[str, object]:
        if self.seed == 2:
            raise ZeroDivisionError("boom")
        return real(self, duration, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(TaskSim, "run", crashing)
    mission = branch_mission()
    planned = [Schedule(s, EVENTS) for s in range(4)]
    outcome = verify(mission, DEFAULT_PROFILE, planned, Pool(workers=1), minimize_classes=False)
    assert [r.seed for r in outcome.results] == [0, 1, 2, 3]
    assert [r.ok for r in outcome.results] == [True, True, False, True]
    (cls,) = outcome.classes
    assert cls.signature.startswith("simulator crash: ZeroDivisionError at actorswarm/")
    assert "--seed 2" in cls.replay
    assert "ZeroDivisionError: boom" in (outcome.results[2].crash or "")


def test_an_interrupted_verify_keeps_what_finished() -> None:
    mission = branch_mission()
    planned = [Schedule(s, EVENTS) for s in range(6)]
    seen: list[int] = []

    def stop_after_two(result: object) -> None:
        seen.append(1)
        if len(seen) == 2:
            raise KeyboardInterrupt

    outcome = verify(mission, DEFAULT_PROFILE, planned, Pool(workers=1), on_result=stop_after_two)
    assert outcome.interrupted and len(outcome.results) == 2


# --- the command ----------------------------------------------------------------------------


def test_verify_command_reports_json_and_a_report_directory(tmp_path: Path) -> None:
    profile = tmp_path / "kills.toml"
    profile.write_text(
        "[radio]\nloss = [0, 0]\nlatency_ms = [10, 10]\njitter_ms = [0, 0]\n"
        "[kills]\nrate = 2\nmaster = 0\nafter_event = 1\nafter_event_s = [0.2, 1]\nrestart = 0\n"
        "[partitions]\nrate = 0\n[events]\nshift = 0\n"
    )
    out = tmp_path / "report"
    code, stdout, stderr = cli(
        "task", "verify", str(BRANCH), "--runs", "4", "--seed", "100", "--workers", "1",
        "--duration", "16", "--done", "A", "--faults", str(profile), "--budget", "12",
        "--json", str(tmp_path / "v.json"), "--report", str(out), "--require", "0.9",
    )  # fmt: skip
    data = json.loads((tmp_path / "v.json").read_text())
    assert data["figures"]["runs"] == 4 and data["seeds"] == [100, 103]
    failed = data["figures"]["failed"]
    assert failed == sum(not r["ok"] for r in data["results"]) > 0
    assert code == 1, stderr  # --require 0.9 with failures
    assert "completed: " in stdout and "replay: actorswarm sim" in stdout
    assert (out / "index.html").is_file() and (out / "report.json").is_file()
    assert (out / "classes.png").is_file()
    assert (out / "class-1.mcap").stat().st_size > 1000
    page = (out / "index.html").read_text()
    assert "Class 1" in page and "actorswarm sim" in page


def test_verify_takes_the_scenario_of_the_script_line() -> None:
    code, stdout, _ = cli(
        "task", "verify", str(BRANCH), "--runs", "2", "--workers", "1", "--done", "A",
        "--json", "-",
    )  # fmt: skip
    data = json.loads(stdout)
    assert [e["name"] for e in data["events"]] == ["AtoBC_branch_event", "finish_event"]
    assert data["world"] is None and code == 0


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--runs", "0"], "--runs"),
        (["--done", "Z"], "--done: the script has no actor 'Z'"),
        (["--event", "nope@3"], "no transition of any actor is on nope"),
        (["--ray", "not an address"], "is not a Ray address"),
        (["--ray", "127.0.0.1:9", "--runs", "1"], "no Ray cluster answers there"),
        (["--workers", "2", "--ray", "local"], "exclude each other"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args: list[str], said: str) -> None:
    code, _, stderr = cli("task", "verify", str(BRANCH), *args)
    assert code == 2 and said in stderr, stderr


def test_bad_files_are_refused_before_anything_runs(tmp_path: Path) -> None:
    profile = tmp_path / "p.toml"
    profile.write_text("[kills]\nplatforms = [1, 99]\n")
    code, _, stderr = cli("task", "verify", str(BRANCH), "--faults", str(profile))
    assert code == 2 and f"{profile}:2: [kills] platforms: the script starts no platform 99" in (
        stderr
    )
    broken = tmp_path / "broken.xml"
    broken.write_text("<TaskScript name='x'><Actor/></TaskScript>")
    code, _, stderr = cli("task", "verify", str(broken))
    assert code == 2 and "must pass `actorswarm task check` first" in stderr
    a_file = tmp_path / "taken"
    a_file.write_text("mine")
    code, _, stderr = cli("task", "verify", str(BRANCH), "--report", str(a_file))
    assert code == 2 and "is a file" in stderr and a_file.read_text() == "mine"


# --- Ray ------------------------------------------------------------------------------------


def test_runs_on_a_local_ray_cluster_give_the_same_results(tmp_path: Path) -> None:
    """A Ray head started by the test, and verify's runs placed on it, in a network
    namespace of their own with loopback only (Ray would otherwise advertise this machine's
    address, not 127.0.0.1): the same verdicts, seed for seed, as in this process."""
    import os
    import shutil
    import subprocess
    import sys
    import tempfile

    pytest.importorskip("ray")
    unshare = shutil.which("unshare")
    if unshare is None or os.geteuid() != 0:
        pytest.skip("a private network namespace needs unshare and root; CI runs as root")
    probe = subprocess.run([unshare, "--net", "true"], check=False, capture_output=True, text=True)
    if probe.returncode != 0:
        pytest.skip(f"network namespaces are unavailable here: {probe.stderr.strip()}")
    bin_dir = Path(sys.executable).parent
    # Short: Ray's session directory holds Unix sockets, whose paths are at most 107 bytes.
    ray_tmp = Path(tempfile.mkdtemp(prefix="ray-", dir="/tmp"))
    out = tmp_path / "ray.json"
    script = f"""
set -e
ip link set lo up
export RAY_USAGE_STATS_ENABLED=0
{bin_dir}/ray start --head --port 6379 --num-cpus 1 --include-dashboard false \
    --disable-usage-stats --temp-dir {ray_tmp} > {ray_tmp}/start.log 2>&1
trap '{bin_dir}/ray stop --force > /dev/null 2>&1' EXIT
{bin_dir}/actorswarm task verify {BRANCH} --runs 3 --seed 100 --duration 16 --done A \
    --ray 127.0.0.1:6379 --budget 1 --json {out}
"""
    try:
        done = subprocess.run(
            [unshare, "--net", "--fork", "bash", "-c", script],
            check=False, capture_output=True, text=True, timeout=240,
        )  # fmt: skip
    finally:
        shutil.rmtree(ray_tmp, ignore_errors=True)
    assert done.returncode in (0, 1), done.stderr[-2000:]
    data = json.loads(out.read_text())
    assert data["where"].startswith("the Ray cluster at 127.0.0.1:6379 (1 CPUs)")
    mission = branch_mission(script_path=str(BRANCH))
    here = verify(
        mission, DEFAULT_PROFILE, schedules(mission, DEFAULT_PROFILE, 100, 3, list(range(1, 11))),
        Pool(workers=1), minimize_classes=False,
    )  # fmt: skip
    assert [r["signature"] for r in data["results"]] == [r.signature for r in here.results]
    assert [r["packets"] for r in data["results"]] == [r.packets for r in here.results]
