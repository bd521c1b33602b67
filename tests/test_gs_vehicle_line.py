"""How ``gs status`` prints what a platform's vehicle says of itself."""

from __future__ import annotations

from actorswarm.cli.gs import _clock_lines, _clock_offset, _status_line, _vehicle_line
from actorswarm.engine import commands as cmds


def test_a_mavlink_vehicle_is_one_readable_clause() -> None:
    line = _vehicle_line(
        {"link": "up", "autopilot": "ardupilot", "mode": "GUIDED", "armed": True,
         "battery": 0.874, "override": "hold"}
    )  # fmt: skip
    assert line == "; vehicle: link up, ardupilot GUIDED, armed, battery 87 %, operator hold"
    assert _vehicle_line({"link": "lost", "armed": False, "battery": None}) == (
        "; vehicle: link lost, disarmed"
    )
    assert _vehicle_line({}) == ""
    assert _vehicle_line({"link": "up", "armed": False, "starting": True}) == (
        "; vehicle: link up, disarmed, starting"
    )


def test_a_vehicle_that_is_not_ready_says_why_and_for_how_long() -> None:
    waiting = {"link": "up", "autopilot": "ardupilot", "mode": "GUIDED", "armed": False,
               "ready": False, "waiting": 23.4, "battery": 1.0,
               "reason": "PreArm: Need Position Estimate"}  # fmt: skip
    assert _vehicle_line(waiting) == (
        "; vehicle: link up, ardupilot GUIDED, disarmed, battery 100 %, not ready 23 s — "
        "PreArm: Need Position Estimate"
    )
    idle = {"link": "up", "armed": False, "ready": False, "waiting": None, "reason": "x"}
    assert _vehicle_line(idle) == "; vehicle: link up, disarmed, not ready — x"
    assert _vehicle_line({"link": "up", "ready": True, "waiting": None}) == "; vehicle: link up"


def test_the_status_reply_carries_the_vehicle_both_ways() -> None:
    reply = cmds.StatusReply(
        actors={}, master=False, epoch=1, incarnation=0, vehicle={"link": "up", "armed": False}
    )
    again = cmds.decode_reply(cmds.encode(reply))
    assert isinstance(again, cmds.StatusReply) and again.vehicle == {"link": "up", "armed": False}
    old = cmds.StatusReply(actors={}, master=False, epoch=1, incarnation=0)
    assert cmds.decode_reply(cmds.encode(old)) == old


def test_a_lost_link_or_a_failed_status_is_an_alarm() -> None:
    from actorswarm.ground.vehicle import alarm, describe

    assert alarm({"link": "lost", "armed": True})
    assert alarm({"error": "RuntimeError: no port"})
    assert describe({"error": "RuntimeError: no port"}) == "status failed: RuntimeError: no port"
    assert not alarm({"link": "up", "mode": "GUIDED"}) and not alarm({})


def test_a_platform_line_names_the_roles_it_holds() -> None:
    row = {"answered": True, "actors": ["Track"], "roles": ["leader", "tracker"],
           "master": True, "epoch": 2, "incarnation": 5, "last_heard_s": 0.4,
           "vehicle": {}}  # fmt: skip
    assert _status_line("3", row) == (
        "  3 (master): Track (roles leader, tracker); epoch 2, incarnation 5, heard 0.4 s ago"
    )
    quiet = {**row, "answered": False, "actors": [], "roles": [], "master": False}
    assert _status_line("4", quiet) == ("  4: no answer; epoch 2, incarnation 5, heard 0.4 s ago")


def _row(began: float | None, offset: float | None) -> dict[str, object]:
    return {"began": began, "clock_offset_s": offset}


def test_gs_status_says_when_the_task_began_and_warns_of_a_clock_that_is_off() -> None:
    """The task's clock needs the platforms' clocks to agree: a clock more than 0.25 s off
    this machine's is named, and so are platforms that run tasks begun at other instants."""
    began = 1_796_688_106.833
    agreed = _clock_lines({"1": _row(began, 0.004), "2": _row(began, -0.1), "3": _row(None, None)})
    assert agreed == ["the task's clock began at 2026-12-08T00:01:46.833Z on 2 platform(s)"]
    off = _clock_lines({"1": _row(began, 0.01), "4": _row(began, -1.3)})
    assert off[1] == (
        "warning: platform 4's clock is 1.30 s behind this machine's: what the swarm does on "
        "the task's clock (a formation's depart) needs their clocks to agree (GPS or NTP)"
    )
    split = _clock_lines({"1": _row(began, 0.0), "2": _row(began + 600, 0.0)})
    assert split == [
        "warning: the platforms run tasks begun at different instants "
        "(2026-12-08T00:01:46.833Z: 1; 2026-12-08T00:11:46.833Z: 2)"
    ]
    assert _clock_lines({}) == []


def test_a_clock_is_called_off_only_beyond_the_doubt_of_its_reading() -> None:
    doubtful = {"began": None, "clock_offset_s": 0.6, "clock_uncertainty_s": 0.4}
    assert _clock_lines({"5": doubtful}) == []
    sure = {"began": None, "clock_offset_s": 0.6, "clock_uncertainty_s": 0.3}
    assert _clock_lines({"5": sure})[0].startswith("warning: platform 5's clock is 0.60 s ahead")


def test_a_platforms_clock_is_read_midway_through_its_answers_round_trip() -> None:
    # Asked at 100.0, answered at 100.2 (this machine's UTC): a platform that read 100.1
    # agrees; one that read 101.6 is 1.5 s ahead.
    assert _clock_offset(100.1, 100.0, 100.2) == 0.0
    assert _clock_offset(101.6, 100.0, 100.2) == 1.5
