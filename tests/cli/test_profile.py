"""Less typing: the ground station's connection settings from a profile file or the
environment, in that order after the command line; what ``launch`` writes reads back."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.cli.gs_control import _ids, _one_refusal
from actorswarm.cli.profile import (
    ENVIRONMENT,
    ProfileError,
    apply_profile,
    profile_text,
    read_profile,
)
from actorswarm.cli.swarm_options import LinkOptions


@pytest.fixture
def seen(monkeypatch: pytest.MonkeyPatch) -> list[LinkOptions]:
    """The options ``gs status`` would connect with (it stops there)."""
    calls: list[LinkOptions] = []

    def fake_link(self: LinkOptions) -> Any:
        calls.append(self)
        raise typer.Exit(0)

    monkeypatch.setattr(LinkOptions, "link", fake_link)
    for variable, _ in ENVIRONMENT.values():
        monkeypatch.delenv(variable, raising=False)
    monkeypatch.delenv("ACTORSWARM_PROFILE", raising=False)
    return calls


def _profile(tmp_path: Path) -> Path:
    path = tmp_path / "gs.toml"
    path.write_text(profile_text("field", ["tcp/10.0.0.1:7447"], False, None, True))
    return path


def test_a_profile_gives_the_connection_settings(tmp_path: Path, seen: list[LinkOptions]) -> None:
    result = CliRunner().invoke(app, ["gs", "--profile", str(_profile(tmp_path)), "status"])
    assert result.exit_code == 0, result.output
    assert seen == [
        LinkOptions(swarm="field", connect=["tcp/10.0.0.1:7447"], multicast=False, insecure=True)
    ]


def test_the_environment_comes_before_the_profile_and_the_command_line_first(
    tmp_path: Path, seen: list[LinkOptions]
) -> None:
    env = {"ACTORSWARM_PROFILE": str(_profile(tmp_path)), "ACTORSWARM_SWARM": "from-env"}
    CliRunner().invoke(app, ["gs", "status"], env=env)
    CliRunner().invoke(app, ["gs", "status", "--swarm", "typed"], env=env)
    assert [call.swarm for call in seen] == ["from-env", "typed"]
    assert all(call.connect == ["tcp/10.0.0.1:7447"] for call in seen)


def test_a_bad_profile_is_one_line_naming_the_key(tmp_path: Path, seen: list[LinkOptions]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('swarm = "x"\nconect = ["tcp/1.2.3.4:5"]\n')
    result = CliRunner().invoke(app, ["gs", "--profile", str(bad), "status"])
    assert result.exit_code == 2 and not seen
    assert result.output.strip().splitlines() == [
        f"{bad}: unknown key 'conect' (did you mean \"connect\"?); the keys: "
        + ", ".join(ENVIRONMENT)
    ]
    missing = CliRunner().invoke(app, ["gs", "--profile", str(tmp_path / "none"), "status"])
    assert missing.exit_code == 2 and "cannot read the profile" in missing.output


def test_profile_values_are_checked_and_paths_are_relative_to_the_file(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text('keys = "keys"\nmulticast = "no"\n')
    with pytest.raises(ProfileError, match="multicast: expected true or false"):
        read_profile(path)
    path.write_text('keys = "keys"\n')
    assert read_profile(path) == {"ACTORSWARM_KEYS": str(tmp_path / "keys")}


def test_applying_a_profile_keeps_what_is_set_and_is_undone(tmp_path: Path) -> None:
    env = {"ACTORSWARM_SWARM": "mine"}
    undo = apply_profile(_profile(tmp_path), env)
    assert env["ACTORSWARM_SWARM"] == "mine" and env["ACTORSWARM_INSECURE"] == "true"
    assert env["ACTORSWARM_CONNECT"] == "tcp/10.0.0.1:7447"
    undo()
    assert env == {"ACTORSWARM_SWARM": "mine"}


def test_one_refusal_for_every_platform_is_one_line() -> None:
    answers = {
        p: (False, f"actor 'Zzz' is not loaded on platform {p} (loaded: A)") for p in range(1, 11)
    }
    assert _one_refusal(list(range(1, 11)), answers) == "actor 'Zzz' is not loaded (loaded: A)"
    answers[3] = (True, "paused A")
    assert _one_refusal(list(range(1, 11)), answers) is None
    assert _ids([1, 2, 3, 4, 7, 9, 10]) == "1-4,7,9-10"


def test_a_daemon_keeps_its_state_under_the_users_state_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from actorswarm.cli.swarm_setup import default_daemon_state

    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path))
    assert default_daemon_state("field", 3) == tmp_path / "actorswarm" / "field" / "platform-3"
    monkeypatch.delenv("XDG_STATE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert default_daemon_state("s", 1) == tmp_path / ".local/state/actorswarm/s/platform-1"
