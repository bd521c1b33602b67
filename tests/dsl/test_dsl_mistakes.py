"""Scripts that say one thing and do another, each refused (or warned about) at the place:
a ``sysNum`` more platforms than can ever run the actor, one ``barrierKey`` on different
events, malformed structured params, area names the world does not have, plugins on a bus
they do not declare."""

from __future__ import annotations

import pytest

from actorswarm.dsl import check
from actorswarm.dsl.diagnostics import Diagnostic

PLUGINS = frozenset({"core.idle", "core.emit_after"})


def where(text: str, piece: str) -> str:
    """``line:col`` of the first ``piece`` in ``text`` (both 1-based)."""
    before = text[: text.index(piece)]
    return f"{before.count(chr(10)) + 1}:{len(before) - before.rfind(chr(10))}"


def at(found: tuple[Diagnostic, ...], place: str, message: str) -> Diagnostic:
    hits = [d for d in found if f"{d.line}:{d.col}" == place and message in d.message]
    assert hits, f"expected {place}: ...{message}..., got:\n" + "\n".join(map(str, found))
    return hits[0]


def mission(escort_sys_num: str, *, escort_key: str = "") -> str:
    """Twelve platforms take off together and split: 4 escort, the rest search; the
    escorts move on together on ``on_station``."""
    actors = "".join(
        f"<Actor><_P_Name>{name}</_P_Name></Actor>\n"
        for name in ("Standby", "Escort", "Search", "Onward", "Track")
    )
    return (
        '<TaskScript name="t">\n<_ActorsConfig>\n' + actors + "</_ActorsConfig>\n<_TaskConfig>\n"
        '<actor name="Standby"><transition name="ready" sysNum="all">\n'
        '<branch cnt="4"><successor actor="Escort"/></branch>\n'
        '<branch cnt="rest"><successor actor="Search"/></branch></transition></actor>\n'
        f'<actor name="Escort"><transition name="on_station" sysNum="{escort_sys_num}" '
        f'{escort_key} timeout="20">\n'
        '<successor actor="Onward"/></transition></actor>\n'
        '<actor name="Search"><transition name="target_detected" barrierKey="3" sysNum="1">\n'
        '<successor actor="Track"/></transition></actor>\n'
        "</_TaskConfig>\n"
        '<_PlatformActorConfig><platform id="1-12" actor="Standby"/></_PlatformActorConfig>\n'
        "</TaskScript>\n"
    )


def test_the_mission_as_meant_is_clean() -> None:
    result = check(mission("4"), path="m.xml", known_plugins=PLUGINS)
    assert result.ok and not result.warnings, "\n".join(map(str, result.diagnostics))


def test_sys_num_above_what_the_branch_counts_send_is_an_error() -> None:
    text = mission("6")
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    found = at(result.errors, where(text, 'sysNum="6"'), "can never fire")
    assert "needs 6 platforms running Escort at once" in found.message
    assert "at most 4 ever run it" in found.message
    assert "only ever end by its timeout of 20 s" in found.message
    assert "lower sysNum to at most 4" in found.message


def test_a_numeric_sys_num_out_of_a_closed_actor_may_fire_several_times() -> None:
    # Standby sends 4 per firing, and 12 // 4 = 3 firings: up to 12 Escorts.
    text = (
        mission("6")
        .replace('sysNum="all"', 'sysNum="4"')
        .replace('<branch cnt="rest"><successor actor="Search"/></branch>', "")
    )
    text = text.replace('cnt="4"', 'cnt="rest"')
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    assert result.ok, "\n".join(map(str, result.errors))


def test_an_actor_entered_again_is_not_bounded_by_counts() -> None:
    # Onward leads back to Standby: Standby is no longer closed, so nothing caps Escort
    # below the 12 platforms that can reach it.
    text = mission("6").replace(
        "</_TaskConfig>",
        '<actor name="Onward"><transition name="again" sysNum="all">'
        '<successor actor="Standby"/></transition></actor>\n</_TaskConfig>',
    )
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    assert result.ok, "\n".join(map(str, result.errors))


def test_one_barrier_key_on_different_events_is_a_warning() -> None:
    text = mission("4", escort_key='barrierKey="3"')
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    assert result.ok
    # Pointed at the second transition of the key, naming the first.
    place = where(text, 'barrierKey="3" sysNum="1"')
    found = at(result.warnings, place, "barrierKey 3 joins")
    first = where(text, 'name="on_station"')
    assert f"target_detected of Search to on_station of Escort at {first}" in found.message
    assert "fires only when both events have come" in found.message
    assert "up to the 20 s timeout" in found.message
    assert str(found).startswith(f"m.xml:{place}: warning: ")


def test_one_barrier_key_on_one_event_is_silent() -> None:
    text = mission("4", escort_key='barrierKey="3"').replace("target_detected", "on_station")
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    assert not any("joins" in d.message for d in result.diagnostics)


@pytest.mark.parametrize("sys_num", ["4", "3"])
def test_sys_num_within_the_counts_passes(sys_num: str) -> None:
    assert check(mission(sys_num), known_plugins=PLUGINS).ok
