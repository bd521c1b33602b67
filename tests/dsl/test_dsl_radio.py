"""task check --world: platforms whose homes are out of each other's radio reach."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from actorswarm.cli.app import app
from actorswarm.dsl import check_file
from actorswarm.world.config import loads_world

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "examples" / "branch_merge.xml"
#: Ten homes 90 m apart on a line: nine hops with a 100 m radio.
LINE = """
[fleet]
kind = "quadrotor"
spacing = 90.0
columns = 10
[radio]
range = {range}
relay = {relay}
"""


def _warnings(radio_range: float, relay: bool) -> list[str]:
    world = loads_world(LINE.format(range=radio_range, relay=str(relay).lower()))
    return [d.message for d in check_file(SCRIPT, world=world).warnings]


def test_homes_beyond_one_hop_without_relay_are_warned_about() -> None:
    (warning,) = _warnings(100.0, relay=False)
    assert "span 9 radio hops" in warning and "relay = true" in warning
    assert _warnings(100.0, relay=True) == []
    assert _warnings(1000.0, relay=False) == []


def test_homes_out_of_reach_even_hop_by_hop_are_warned_about() -> None:
    for relay in (False, True):
        (warning,) = _warnings(50.0, relay=relay)
        assert "10 groups out of each other's radio reach" in warning


def test_task_check_says_how_many_hops_a_relayed_swarm_spans(tmp_path: Path) -> None:
    world = tmp_path / "line.toml"
    world.write_text(LINE.format(range=100.0, relay="true"))
    result = CliRunner().invoke(app, ["task", "check", str(SCRIPT), "--world", str(world)])
    assert result.exit_code == 0, result.output
    assert "homes span 9 radio hop(s), relayed" in result.output
