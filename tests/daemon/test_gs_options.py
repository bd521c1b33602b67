"""The ground-station commands refuse unusable options with exit status 2 and a message,
before they open a session."""

from __future__ import annotations

from pathlib import Path

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


EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _unwarned(stderr: str) -> str:
    """``stderr`` without the warning every --insecure command prints first."""
    return "".join(
        line for line in stderr.splitlines(keepends=True) if not line.startswith("WARNING: ")
    )


class _Sent(Exception):
    """Raised where gs deploy would open its session: the script got past the checks."""


def test_deploy_with_a_world_refuses_an_unknown_area_before_sending(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from actorswarm.cli.swarm_options import Link

    opened: list[str] = []

    def session(self: Link, patience: float | None = None) -> object:
        opened.append(self.swarm)
        raise _Sent

    monkeypatch.setattr(Link, "session", session)
    world = str(EXAMPLES / "worlds" / "search_track_10.toml")
    good = EXAMPLES / "search_track_10.xml"
    bad = tmp_path / "serch.xml"
    bad.write_text(
        good.read_text().replace(
            '<param key="area" value="search"/><param key="altitude"',
            '<param key="area" value="serch"/><param key="altitude"',
        )
    )
    deploy = ["gs", "deploy", "--expect", "10", "--insecure", "--state", str(tmp_path / "s.json")]
    refused = runner.invoke(app, [*deploy, "--world", world, str(bad)])
    assert refused.exit_code == 1, refused.output
    assert opened == [] and not (tmp_path / "s.json").exists()
    # The very lines task check prints for the same script and world.
    checked = runner.invoke(app, ["task", "check", "--world", world, str(bad)])
    assert checked.exit_code == 1
    assert _unwarned(refused.stderr) == checked.stderr
    assert "search.area: the world has no area 'serch' (did you mean \"search\"?)" in (
        refused.stderr
    )
    # Without the world the name cannot be judged, and the script goes on to be sent; so
    # does the right script with the world.
    for args in ([str(bad)], ["--world", world, str(good)]):
        result = runner.invoke(app, [*deploy, *args])
        assert isinstance(result.exception, _Sent), result.output
    assert opened == ["swarm", "swarm"]


def test_deploy_refuses_an_unreadable_world_or_script_with_exit_2(tmp_path: Path) -> None:
    world = tmp_path / "w.toml"
    world.write_text("[world]\nstep = -1\n")
    script = str(EXAMPLES / "branch_merge.xml")
    deploy = ["gs", "deploy", "--expect", "2", "--insecure"]
    result = runner.invoke(app, [*deploy, "--world", str(world), script])
    assert result.exit_code == 2 and str(world) in result.stderr
    missing = tmp_path / "nope.xml"
    result = runner.invoke(app, [*deploy, str(missing)])
    assert result.exit_code == 2
    assert _unwarned(result.stderr).startswith(f"{missing}: cannot read the file")
