"""Value syntax: numbers in ASCII digits only, platform ID lists, and the plugins a script
may name."""

from __future__ import annotations

from importlib.metadata import EntryPoint

import pytest
from hypothesis import given
from hypothesis import strategies as st

from actorswarm.dsl import plugins, syntax


@given(st.frozensets(st.integers(min_value=1, max_value=65535), min_size=1, max_size=50))
def test_platform_id_lists_round_trip(ids: frozenset[int]) -> None:
    assert syntax.platform_ids(syntax.id_ranges(ids)) == ids


@pytest.mark.parametrize(
    ("text", "ids"),
    [("7", {7}), (" 1 - 3 , 9 ", {1, 2, 3, 9}), ("1,3,5-7", {1, 3, 5, 6, 7}), ("65535", {65535})],
)
def test_platform_id_lists(text: str, ids: set[int]) -> None:
    assert syntax.platform_ids(text) == ids


@pytest.mark.parametrize("text", ["1_000", "٣", "+5", " ", "1e3", "99999999999999999999999"])
def test_integers_are_plain_ascii_digits(text: str) -> None:
    with pytest.raises(ValueError, match="must be an integer from 1 to 63"):
        syntax.integer(text, what="barrierKey", low=1, high=63)


@pytest.mark.parametrize("text", ["nan", "inf", "1e999", "1_0", "", "0x10"])
def test_numbers_are_finite_decimals(text: str) -> None:
    with pytest.raises(ValueError, match="must be a number"):
        syntax.number(text, what="after")


@pytest.mark.parametrize(("text", "value"), [("2", 2.0), ("0.5", 0.5), (".5", 0.5), ("1e-3", 1e-3)])
def test_numbers(text: str, value: float) -> None:
    assert syntax.number(text, what="after") == value


def test_installed_plugins_are_the_entry_points_and_the_built_ins(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    found = [EntryPoint("formation.arrow", "pkg.formations:Arrow", plugins.ENTRY_POINT_GROUP)]
    asked: list[str] = []

    def fake_entry_points(*, group: str) -> list[EntryPoint]:
        asked.append(group)
        return found

    monkeypatch.setattr(plugins, "entry_points", fake_entry_points)
    assert plugins.installed_plugins() == {"formation.arrow", "core.idle", "core.emit_after"}
    assert asked == ["actorswarm.plugins"]
