"""The ground-station commands' connection options are declared once (``LinkOptions``) and
every ``gs`` command has exactly those, with the same names, defaults, environment
variables and help: the commands are walked from the typer app, so a new one is checked
too, and an option declared again by hand beside them fails here."""

from __future__ import annotations

from dataclasses import fields
from typing import Annotated, Any

import pytest
import typer
import typer.main
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.cli.profile import ENVIRONMENT
from actorswarm.cli.swarm_options import LinkOptions, link_options

NAMES = [f.name for f in fields(LinkOptions)]


def _gs_commands() -> dict[str, Any]:
    """The ``gs`` group's commands (typer's click objects), by name."""
    gs: Any = typer.main.get_command(app)
    return dict(gs.commands["gs"].commands)


def _described(param: Any) -> tuple[Any, ...]:
    """What the user sees of an option: its flags, default, environment variable, help."""
    return (param.opts, param.secondary_opts, param.default, param.envvar, param.help,
            param.metavar, param.multiple, param.is_flag)  # fmt: skip


def test_every_gs_command_has_exactly_the_shared_connection_options() -> None:
    commands = _gs_commands()
    assert {"deploy", "start", "status", "event", "force", "pause", "activate", "stop",
            "backup", "record", "web", "ros2"} <= set(commands)  # fmt: skip
    reference = None
    for name, command in commands.items():
        shared = [p for p in command.params if p.name in NAMES]
        assert [p.name for p in shared] == NAMES, name
        # Side by side in the help, in LinkOptions' order.
        at = command.params.index(shared[0])
        assert command.params[at : at + len(NAMES)] == shared, name
        described = [_described(p) for p in shared]
        reference = reference or described
        assert described == reference, name
        # No other option reads the connection settings' environment (a second declaration).
        others = [p for p in command.params if p.name not in NAMES]
        assert not [p.name for p in others if str(p.envvar or "").startswith("ACTORSWARM_")]
    # The environment variables are the ones a profile sets (actorswarm.cli.profile).
    envvars = {d[0][0].removeprefix("--").split("/")[0]: d[3] for d in reference or []}
    assert envvars == {key: variable for key, (variable, _) in ENVIRONMENT.items()}


def test_link_options_packs_the_options_into_one_object(monkeypatch: pytest.MonkeyPatch) -> None:
    got: list[tuple[str, LinkOptions, int]] = []

    @link_options
    def command(
        word: Annotated[str, typer.Argument()],
        conn: LinkOptions,
        count: Annotated[int, typer.Option()] = 1,
    ) -> None:
        got.append((word, conn, count))

    single = typer.Typer()
    single.command()(command)
    monkeypatch.setenv("ACTORSWARM_GROUP", "239.1.2.3:7000")
    args = ["hi", "--swarm", "s", "--connect", "tcp/a:1", "--connect", "tcp/b:2",
            "--no-multicast", "--insecure", "--count", "3"]  # fmt: skip
    result = CliRunner().invoke(single, args)
    assert result.exit_code == 0, result.output
    expected = LinkOptions(
        swarm="s",
        connect=["tcp/a:1", "tcp/b:2"],
        multicast=False,
        group="239.1.2.3:7000",
        insecure=True,
    )
    assert got == [("hi", expected, 3)]


def test_a_command_must_take_the_options_once_and_not_declare_them() -> None:
    def without(count: int = 1) -> None:
        pass

    def twice(a: LinkOptions, b: LinkOptions) -> None:
        pass

    def again(conn: LinkOptions, swarm: str = "x") -> None:
        pass

    for command in (without, twice, again):
        with pytest.raises(TypeError, match="one LinkOptions parameter"):
            link_options(command)
