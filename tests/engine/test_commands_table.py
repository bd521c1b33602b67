"""One command vocabulary: each operator command has one handler on the platform, and each
of the page's command requests maps onto one of those commands."""

from __future__ import annotations

import typing

from actorswarm.engine import commands as cmds
from actorswarm.engine import engine
from actorswarm.web import protocol as proto
from actorswarm.web.operator import PAGE_COMMANDS


def test_every_command_has_one_handler() -> None:
    assert set(engine._COMMAND_HANDLERS) == set(typing.get_args(cmds.Command))


def test_page_requests_map_onto_commands_the_platforms_handle() -> None:
    # checked on the page's host, deployed in chunks, started with its hash, or steering
    # the page's own replay: not a single command to the platforms
    page_only = {proto.Check, proto.Deploy, proto.Start, proto.Speed, proto.Play, proto.Seek}
    assert set(PAGE_COMMANDS) == set(typing.get_args(proto.Command)) - page_only
    request = proto.StopActor(id="r1", actor="Scan", platforms="1-3")
    command, asked = PAGE_COMMANDS[proto.StopActor](request)
    assert command == cmds.ForceStop(actor="Scan") and asked == "stop Scan"
    assert type(command) in engine._COMMAND_HANDLERS
