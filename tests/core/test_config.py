"""CoreConfig: docs/design.md defaults, validation that names the field, retry delays, mappings."""

from __future__ import annotations

import math
from typing import Any

import pytest

from actorswarm.core.config import ConfigError, CoreConfig


@pytest.mark.parametrize(
    ("field", "expected"),
    [
        ("heartbeat_interval", 0.1),
        ("join_heartbeats", 3),
        ("t_join", 1.0),
        ("t_leave", 0.5),
        ("detector", "timeout"),
        ("takeover_on_join", False),
    ],
)
def test_defaults_match_design(field: str, expected: object) -> None:
    value = getattr(CoreConfig(), field)
    assert value == expected, f"default {field} is {value!r}, docs/design.md §3 says {expected!r}"


def test_default_startup_wait_covers_a_join() -> None:
    config = CoreConfig()
    needed = (config.join_heartbeats - 1) * config.heartbeat_interval
    assert config.startup_wait > needed, (
        f"startup_wait {config.startup_wait} must exceed the {needed} s a join takes"
    )
    assert CoreConfig(boot_wait=0.0).startup_wait == 0.0, "boot_wait overrides startup_wait"
    assert CoreConfig(boot_wait=2.5).startup_wait == 2.5


BAD_VALUES: list[tuple[str, dict[str, Any]]] = [
    ("heartbeat_interval", {"heartbeat_interval": 0}),
    ("heartbeat_interval", {"heartbeat_interval": -0.1}),
    ("heartbeat_interval", {"heartbeat_interval": math.nan}),
    ("heartbeat_interval", {"heartbeat_interval": math.inf}),
    ("heartbeat_interval", {"heartbeat_interval": "0.1"}),
    ("heartbeat_interval", {"heartbeat_interval": True}),
    ("t_join", {"t_join": 0.0}),
    ("t_join", {"t_join": 0.19}),  # 3 heartbeats 0.1 s apart need 0.2 s
    ("t_leave", {"t_leave": -1.0}),
    ("t_leave", {"t_leave": 0.1}),  # not above the heartbeat interval
    ("t_leave", {"t_leave": 0.05}),
    ("phi_threshold", {"phi_threshold": 0}),
    ("phi_min_std", {"phi_min_std": -0.01}),
    ("retry_base", {"retry_base": 0}),
    ("retry_cap", {"retry_cap": 0.01}),  # below retry_base
    ("retry_cap", {"retry_cap": None}),
    ("retry_step", {"retry_step": -0.01}),
    ("retry_step", {"retry_step": math.inf}),
    ("delivery_deadline", {"delivery_deadline": 0}),
    ("handshake_timeout", {"handshake_timeout": -2.0}),
    ("join_heartbeats", {"join_heartbeats": 0}),
    ("join_heartbeats", {"join_heartbeats": 2.5}),
    ("join_heartbeats", {"join_heartbeats": True}),
    ("phi_window", {"phi_window": 1}),
    ("window", {"window": 0}),
    ("max_packet_bytes", {"max_packet_bytes": 100}),
    ("release_chunk", {"release_chunk": 0}),
    ("detector", {"detector": "gossip"}),
    ("detector", {"detector": None}),
    ("boot_wait", {"boot_wait": -1.0}),
    ("boot_wait", {"boot_wait": math.nan}),
    ("fast_master_loss", {"fast_master_loss": 0}),
    ("fast_master_loss", {"fast_master_loss": 1.0}),
    ("fast_master_loss", {"fast_master_loss": math.nan}),
    ("fast_master_loss", {"fast_master_loss": True}),
    ("fast_master_loss", {"fast_master_loss": "0.2"}),
]


@pytest.mark.parametrize(
    ("field", "changes"), BAD_VALUES, ids=[f"{f}={v!r}" for f, c in BAD_VALUES for v in c.values()]
)
def test_bad_value_raises_config_error_naming_field(field: str, changes: dict[str, Any]) -> None:
    with pytest.raises(ConfigError) as info:
        CoreConfig(**changes)
    assert field in str(info.value), f"message {str(info.value)!r} does not name {field!r}"


@pytest.mark.parametrize(("field", "changes"), BAD_VALUES[:6])
def test_replace_validates_too(field: str, changes: dict[str, Any]) -> None:
    with pytest.raises(ConfigError, match=field):
        CoreConfig().replace(**changes)


@pytest.mark.parametrize(
    ("field", "value"), [("retry_step", "0.04"), ("retry_step", None), ("boot_wait", "soon")]
)
def test_non_number_raises_config_error_naming_field(field: str, value: Any) -> None:
    with pytest.raises(ConfigError, match=field):
        CoreConfig(**{field: value})


def test_from_mapping_wrong_type_names_field() -> None:
    with pytest.raises(ConfigError, match="boot_wait"):
        CoreConfig.from_mapping({"boot_wait": "soon"})


def test_takeover_on_join_must_be_bool() -> None:
    with pytest.raises(ConfigError, match="takeover_on_join"):
        CoreConfig.from_mapping({"takeover_on_join": "no"})


@pytest.mark.parametrize(
    ("retries", "expected"),
    [
        (0, 0.04),
        (1, 0.08),
        (2, 0.12),
        (5, 0.24),
        (9, 0.40),
        (10, 0.40),
        (1000, 0.40),
    ],
)
def test_retry_delay_linear_then_capped(retries: int, expected: float) -> None:
    delay = CoreConfig(retry_base=0.04, retry_step=0.04, retry_cap=0.4).retry_delay(retries)
    assert delay == pytest.approx(expected), f"retry_delay({retries}) = {delay}, want {expected}"


def test_retry_delay_with_zero_step_is_constant() -> None:
    config = CoreConfig(retry_base=0.1, retry_step=0.0, retry_cap=0.1)
    assert [config.retry_delay(k) for k in range(5)] == [0.1] * 5


def test_from_mapping_builds_a_validated_config() -> None:
    config = CoreConfig.from_mapping({"heartbeat_interval": 0.05, "t_leave": 0.3, "window": 4})
    assert (config.heartbeat_interval, config.t_leave, config.window) == (0.05, 0.3, 4)
    assert config.t_join == 1.0, "unspecified fields keep their defaults"


def test_from_mapping_refuses_unknown_keys_by_name() -> None:
    with pytest.raises(ConfigError) as info:
        CoreConfig.from_mapping({"heartbeat_intervall": 0.1, "t_leave": 0.5, "zzz": 1})
    message = str(info.value)
    assert "heartbeat_intervall" in message, message
    assert "zzz" in message, message
    unknown_part = message.split(";", maxsplit=1)[0]
    assert "t_leave" not in unknown_part, f"a known key is reported as unknown: {message}"


def test_from_mapping_bad_value_raises_config_error() -> None:
    with pytest.raises(ConfigError, match="window"):
        CoreConfig.from_mapping({"window": 0})


def test_config_is_frozen() -> None:
    config = CoreConfig()
    with pytest.raises(AttributeError):
        config.t_leave = 1.0  # type: ignore[misc]


def test_retry_delay_starts_from_a_measured_base() -> None:
    config = CoreConfig(retry_base=0.04, retry_step=0.02, retry_cap=0.1)
    assert config.retry_delay(0, base=0.025) == pytest.approx(0.025)
    assert config.retry_delay(2, base=0.025) == pytest.approx(0.065)
    assert config.retry_delay(9, base=0.025) == pytest.approx(0.1)


def test_a_config_file_turns_the_fast_master_off_with_false() -> None:
    assert CoreConfig.from_mapping({"fast_master_loss": False}).fast_master_loss is None
    assert CoreConfig.from_mapping({"fast_master_loss": 0.25}).fast_master_loss == 0.25
    with pytest.raises(ConfigError, match="fast_master_loss"):
        CoreConfig.from_mapping({"fast_master_loss": True})
