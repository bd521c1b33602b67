"""How ``gs status`` prints what a platform's vehicle says of itself."""

from __future__ import annotations

from actorswarm.cli.gs import _status_line, _vehicle_line
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
