"""The ground-station commands refuse unusable options with exit status 2 and a message,
before they open a session."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.cli.common import id_list, int_list_or_count

runner = CliRunner()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("force", "A"), "say where to: --to ACTOR"),
        (("force", "--to", "B"), "say who moves"),
        (("force", "A", "--to", "B", "--param", "novalue"), "--param 'novalue': write KEY=VALUE"),
        (("force", "A", "--to", "B", "--param", "=x"), "write KEY=VALUE"),
        (("pause", "A", "--platforms", "x-y"), "--platforms"),
        (("backup", "--platforms", "0"), "--platforms"),
        (("event", "go", "--swarm", "a b"), "swarm name 'a b'"),
        (("stop", "A", "--keys", "/nonexistent/keys"), "keys init"),
    ],
)
def test_bad_ground_station_options_exit_2(args: tuple[str, ...], message: str) -> None:
    extra = () if "--keys" in args else ("--insecure",)
    result = runner.invoke(app, ["gs", *args, *extra])
    assert result.exit_code == 2, result.output
    assert message in result.output


@pytest.mark.parametrize("role", ["gs", "daemon"])
def test_a_missing_key_directory_gets_one_clean_hint(role: str) -> None:
    """The hint names the directory once, in a command that runs as written."""
    args = ["gs", "status"] if role == "gs" else ["daemon", "--platform", "1"]
    result = runner.invoke(app, [*args, "--keys", "/nonexistent/keys"])
    assert result.exit_code == 2
    assert result.output.count("--dir") == 1
    assert "create keys with `actorswarm keys init --dir /nonexistent/keys`" in result.output
    assert "DIR" not in result.output and "--insecure" in result.output


def test_platforms_are_ids_and_expect_may_be_a_count() -> None:
    assert id_list("4", "--platforms") == [4]
    assert id_list("1-3, 7", "--platforms") == [1, 2, 3, 7]
    assert int_list_or_count("4", "--expect") == [1, 2, 3, 4]
    assert int_list_or_count("4,5", "--expect") == [4, 5]


def test_sessions_opened_within_one_second_are_new_incarnations(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # ``gs deploy`` then ``gs start`` often run in one second; if both sessions had the same
    # incarnation the platforms would drop the second one's packets as replays.
    from actorswarm.daemon import ground

    now = [1_790_000_000_000_000_000]
    monkeypatch.setattr(ground.time, "time_ns", lambda: now[0])
    monkeypatch.setattr(ground, "_last", [0])  # as in a new process
    first = ground.session_incarnation()
    now[0] += 200_000_000  # 0.2 s later: the same second
    second = ground.session_incarnation()
    third = ground.session_incarnation()  # the same microsecond, in one process
    assert first < second < third
    assert second == now[0] // 1_000
