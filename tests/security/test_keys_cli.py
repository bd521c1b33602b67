"""``actorswarm keys init`` and ``keys show``: key files with safe modes, fingerprints only."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from typer.testing import CliRunner

from actorswarm.cli.keys import keys_app
from actorswarm.security import init_keys, load_keys

runner = CliRunner()


def test_init_then_show_print_the_same_fingerprints_and_no_secret(tmp_path: Path) -> None:
    directory = tmp_path / "keys"
    result = runner.invoke(keys_app, ["init", "--dir", str(directory)])
    assert result.exit_code == 0, result.output
    keys = load_keys(directory, need_private=True)
    assert f"Created keys in {directory}" in result.output
    assert keys.swarm_fingerprint in result.output and keys.gs_fingerprint in result.output
    assert stat.S_IMODE(os.stat(directory / "swarm.key").st_mode) == 0o600

    shown = runner.invoke(keys_app, ["show", "--dir", str(directory)])
    assert shown.exit_code == 0, shown.output
    assert keys.swarm_fingerprint in shown.output and keys.gs_fingerprint in shown.output
    assert "private key present and matching" in shown.output
    secret_text = (directory / "swarm.key").read_text().strip()
    private_pem = (directory / "ground_station.key").read_text()
    for output in (result.output, shown.output):
        assert secret_text not in output and secret_text[:16] not in output
        assert "PRIVATE KEY" not in output and private_pem.splitlines()[1] not in output


def test_init_refuses_to_overwrite_unless_forced(tmp_path: Path) -> None:
    init_keys(tmp_path)
    before = load_keys(tmp_path).swarm_fingerprint
    result = runner.invoke(keys_app, ["init", "--dir", str(tmp_path)])
    assert result.exit_code == 1
    assert "already holds keys" in result.output and "keys init --force" in result.output
    assert "force=True" not in result.output
    assert load_keys(tmp_path).swarm_fingerprint == before
    forced = runner.invoke(keys_app, ["init", "--dir", str(tmp_path), "--force"])
    assert forced.exit_code == 0, forced.output
    assert load_keys(tmp_path).swarm_fingerprint != before


def test_show_on_a_platform_without_the_private_key(tmp_path: Path) -> None:
    init_keys(tmp_path)
    (tmp_path / "ground_station.key").unlink()
    result = runner.invoke(keys_app, ["show", "--dir", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "private key absent" in result.output


def test_show_reports_a_key_file_problem_with_its_fix(tmp_path: Path) -> None:
    init_keys(tmp_path)
    os.chmod(tmp_path / "swarm.key", 0o644)
    result = runner.invoke(keys_app, ["show", "--dir", str(tmp_path)])
    assert result.exit_code == 1
    assert f"chmod 600 {tmp_path / 'swarm.key'}" in result.output
    missing = runner.invoke(keys_app, ["show", "--dir", str(tmp_path / "none")])
    assert missing.exit_code == 1 and "actorswarm keys init" in missing.output


def test_default_directory_is_under_the_config_home(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    result = runner.invoke(keys_app, ["init"])
    assert result.exit_code == 0, result.output
    directory = tmp_path / "actorswarm" / "keys"
    assert stat.S_IMODE(os.stat(directory).st_mode) == 0o700
    assert runner.invoke(keys_app, ["show"]).exit_code == 0


def test_no_arguments_prints_help() -> None:
    result = runner.invoke(keys_app, [])
    assert "init" in result.output and "show" in result.output
