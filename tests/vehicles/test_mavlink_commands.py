"""The command sender: retries until COMMAND_ACK, refusals, deadlines, ordered steps."""

from __future__ import annotations

from typing import Any

import pytest

from actorswarm.vehicles.mavlink.commands import Check, Command, CommandSender, Do
from actorswarm.vehicles.mavlink.dialect import mav

ARM = Command(mav.MAV_CMD_COMPONENT_ARM_DISARM, (1, 0, 0, 0, 0, 0, 0))
TAKEOFF = Command(mav.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0, 0, 0, 10))


def ack(command: int, result: int) -> Any:
    return mav.MAVLink_command_ack_message(command, result, 0, 0, 245, 191)


@pytest.fixture
def sent() -> list[Any]:
    return []


@pytest.fixture
def sender(sent: list[Any]) -> CommandSender:
    return CommandSender("platform 3", sent.append, (7, 1), retry=0.5, deadline=2.0)


def test_retried_until_acked_then_next_step(sender: CommandSender, sent: list[Any]) -> None:
    sender.start("takeoff", [ARM, TAKEOFF], 0.0)
    assert [m.command for m in sent] == [mav.MAV_CMD_COMPONENT_ARM_DISARM]
    assert (sent[0].target_system, sent[0].target_component) == (7, 1)
    sender.tick(0.3)
    assert len(sent) == 1  # not yet due again
    sender.tick(0.5)
    sender.tick(1.0)
    assert [m.confirmation for m in sent] == [0, 1, 2]  # the protocol counts the repeats
    sender.on_ack(ack(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_RESULT_ACCEPTED), 1.1)  # not this one
    assert sender.busy == "takeoff" and len(sent) == 3
    sender.on_ack(ack(mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_ACCEPTED), 1.2)
    assert sent[-1].command == mav.MAV_CMD_NAV_TAKEOFF and sent[-1].param7 == 10
    sender.on_ack(ack(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_RESULT_ACCEPTED), 1.3)
    assert sender.busy is None and sender.completed == ["takeoff"]
    assert sender.drain_errors() == []


def test_refusal_names_vehicle_plan_command_and_result(
    sender: CommandSender, sent: list[Any]
) -> None:
    sender.start("takeoff", [ARM, TAKEOFF], 0.0)
    sender.on_ack(ack(mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_DENIED), 0.1)
    assert sender.drain_errors() == [
        "vehicle platform 3: takeoff: MAV_CMD_COMPONENT_ARM_DISARM refused by the autopilot: "
        "MAV_RESULT_DENIED"
    ]
    sender.tick(5.0)
    assert len(sent) == 1 and sender.busy is None  # the take-off was never sent
    assert sender.completed == []


def test_silent_autopilot_fails_at_the_deadline(sender: CommandSender, sent: list[Any]) -> None:
    sender.start("land", [ARM], 0.0)
    t = 0.0
    while t < 10.0:
        t += 0.1
        sender.tick(t)
    errors = sender.drain_errors()
    assert len(errors) == 1
    assert (
        "vehicle platform 3: land: MAV_CMD_COMPONENT_ARM_DISARM: not done within 2 s" in (errors[0])
    )
    assert f"({len(sent)} tries)" in errors[0]
    assert 4 <= len(sent) <= 5  # every 0.5 s for 2 s, then nothing more
    assert sender.busy is None


def test_in_progress_stops_repeats_until_the_final_answer(
    sender: CommandSender, sent: list[Any]
) -> None:
    sender.start("takeoff", [TAKEOFF], 0.0)
    sender.on_ack(ack(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_RESULT_IN_PROGRESS), 0.1)
    sender.tick(1.5)
    assert len(sent) == 1
    sender.on_ack(ack(mav.MAV_CMD_NAV_TAKEOFF, mav.MAV_RESULT_ACCEPTED), 1.6)
    assert sender.completed == ["takeoff"]


def test_checks_and_actions(sender: CommandSender, sent: list[Any]) -> None:
    known: list[bool | str | None] = [None]
    done: list[str] = []
    steps = [Do("first", lambda: done.append("first")), Check("params", lambda: known[0]), ARM]
    sender.start("takeoff", steps, 0.0)
    assert done == ["first"] and sent == []  # waiting for the check
    known[0] = True
    sender.tick(0.2)
    assert len(sent) == 1
    known[0] = "FS_GCS_ENABLE is 0"
    sender.start("again", [Check("params", lambda: known[0]), ARM], 1.0)
    assert sender.drain_errors() == ["vehicle platform 3: again: params: FS_GCS_ENABLE is 0"]
    assert len(sent) == 1


def test_a_new_plan_replaces_the_old(sender: CommandSender, sent: list[Any]) -> None:
    sender.start("takeoff", [ARM, TAKEOFF], 0.0)
    sender.start("land", [Command(mav.MAV_CMD_NAV_LAND)], 0.1)
    sender.on_ack(ack(mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_ACCEPTED), 0.2)
    assert [m.command for m in sent] == [mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_CMD_NAV_LAND]
    assert sender.busy == "land"


def test_bad_timing_is_refused() -> None:
    with pytest.raises(ValueError, match="retry and deadline"):
        CommandSender("x", print, (1, 1), retry=0)


def test_temporarily_rejected_is_tried_again_until_the_deadline(
    sender: CommandSender, sent: list[Any]
) -> None:
    sender.start("hold", [ARM], 0.0)
    sender.on_ack(ack(mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_TEMPORARILY_REJECTED), 0.1)
    sender.tick(0.6)
    assert len(sent) == 2 and sender.busy == "hold"  # tried again, not given up
    sender.on_ack(ack(mav.MAV_CMD_COMPONENT_ARM_DISARM, mav.MAV_RESULT_TEMPORARILY_REJECTED), 0.7)
    for t in (1.2, 1.7, 2.2):
        sender.tick(t)
    assert sender.drain_errors() == [
        "vehicle platform 3: hold: MAV_CMD_COMPONENT_ARM_DISARM: not done within 2 s "
        "(4 tries), temporarily rejected"
    ]


def test_a_persisting_command_is_asked_again_with_back_off_until_its_plan_deadline(
    sent: list[Any],
) -> None:
    refusals: list[tuple[str, int]] = []
    sender = CommandSender(
        "platform 3",
        sent.append,
        (7, 1),
        retry=0.5,
        deadline=2.0,
        explain=lambda: "Arm: Need Position Estimate",
        on_refused=lambda name, result: refusals.append((name, result)),
    )
    ready = [False]
    arm = Command(ARM.command, ARM.params, persist=True, deadline=10.0, from_plan=True)
    wait = Check("ready", lambda: True if ready[0] else None, deadline=10.0, from_plan=True)
    sender.start("takeoff", [wait, arm, TAKEOFF], 0.0)
    sender.tick(3.0)
    assert sent == [] and sender.step is wait  # waits past the sender's own 2 s deadline
    ready[0] = True
    sender.tick(3.5)
    assert [m.command for m in sent] == [ARM.command]
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_FAILED), 3.6)
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_FAILED), 3.61)  # the same try's again
    sender.tick(4.5)
    assert len(sent) == 1  # the back-off: 1 s
    sender.tick(4.65)
    assert len(sent) == 2
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_FAILED), 4.7)
    sender.tick(6.6)
    assert len(sent) == 2  # then 2 s
    sender.tick(6.75)
    assert len(sent) == 3
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_FAILED), 6.8)
    sender.tick(10.0)
    assert len(sent) == 3  # then 4 s (at 10.8), past the plan's deadline (10 s)
    sender.tick(10.05)
    assert refusals == [(ARM.name, mav.MAV_RESULT_FAILED)] * 3
    assert sender.drain_errors() == [
        "vehicle platform 3: takeoff: MAV_CMD_COMPONENT_ARM_DISARM: not done within 10 s "
        "(3 tries), last refused: MAV_RESULT_FAILED — Arm: Need Position Estimate"
    ]
    assert sender.busy is None


def test_a_persisting_command_accepted_goes_on(sender: CommandSender, sent: list[Any]) -> None:
    arm = Command(ARM.command, ARM.params, persist=True, deadline=10.0, from_plan=True)
    sender.start("takeoff", [arm, TAKEOFF], 0.0)
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_TEMPORARILY_REJECTED), 0.1)
    sender.tick(1.1)
    assert len(sent) == 2
    sender.on_ack(ack(ARM.command, mav.MAV_RESULT_ACCEPTED), 1.2)
    assert sent[-1].command == mav.MAV_CMD_NAV_TAKEOFF and sender.drain_errors() == []
