"""Scripts that say one thing and do another, each refused (or warned about) at the place:
a ``sysNum`` more platforms than can ever run the actor, one ``barrierKey`` on different
events, malformed structured params, area names the world does not have, plugins on a bus
they do not declare."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import pytest

from actorswarm.dsl import check, rules
from actorswarm.dsl.diagnostics import Diagnostic
from actorswarm.dsl.plugins import installed_plugins
from actorswarm.runtime.context import PluginContext
from actorswarm.runtime.plugin import Param, Plugin

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


def test_a_timeout_branch_out_of_a_closed_actor_carries_all_of_it() -> None:
    # On timeout every waiting Standby goes to Escort: up to 12 Escorts.
    text = mission("6").replace(
        'sysNum="all">', 'sysNum="all" timeout="30" timeoutBranch="Escort">'
    )
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
    assert "until it comes or the group's timeout expires" in found.message
    untimed = check(text.replace(' timeout="20"', ""), known_plugins=PLUGINS)
    assert any("for ever if it never comes (no timeout)" in d.message for d in untimed.warnings)
    assert str(found).startswith(f"m.xml:{place}: warning: ")


def test_one_barrier_key_on_one_event_is_silent() -> None:
    text = mission("4", escort_key='barrierKey="3"').replace("target_detected", "on_station")
    result = check(text, path="m.xml", known_plugins=PLUGINS)
    assert not any("joins" in d.message for d in result.diagnostics)


@pytest.mark.parametrize("sys_num", ["4", "3"])
def test_sys_num_within_the_counts_passes(sys_num: str) -> None:
    assert check(mission(sys_num), known_plugins=PLUGINS).ok


# --- plugins: their params, the world's areas, their bus ----------------------------------


def searcher(plugins: str, transition_params: str = "") -> str:
    """Platforms 1-3 take off and then search: ``plugins`` are Search's buses."""
    return (
        '<TaskScript name="s">\n<_ActorsConfig>\n'
        "<Actor><_P_Name>Standby</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        "<Plugin><_P_Name>flight.takeoff</_P_Name></Plugin></Bus></OODAConfig></Actor>\n"
        f"<Actor><_P_Name>Search</_P_Name><OODAConfig>\n{plugins}\n</OODAConfig></Actor>\n"
        "</_ActorsConfig>\n<_TaskConfig>\n"
        '<actor name="Standby"><transition name="ready" sysNum="all">\n'
        f'{transition_params}<successor actor="Search"/></transition></actor>\n'
        "</_TaskConfig>\n"
        '<_PlatformActorConfig><platform id="1-3" actor="Standby"/></_PlatformActorConfig>\n'
        "</TaskScript>\n"
    )


def act(plugin: str, params: str = "", bus: str = "act_bus") -> str:
    return (
        f"<Bus><_P_Name>{bus}</_P_Name><Plugin><_P_Name>{plugin}</_P_Name>{params}</Plugin></Bus>"
    )


def problems(text: str, areas: list[str] | None = None) -> tuple[Diagnostic, ...]:
    return check(text, path="s.xml", areas=areas).diagnostics


def test_the_searcher_as_meant_is_clean() -> None:
    text = searcher(
        act("detect.target", '<param key="kind" value="jeep"/>', "observe_bus")
        + act("search.area", '<param key="area" value="search"/>')
    )
    assert problems(text, areas=["field", "search"]) == ()


@pytest.mark.parametrize(
    ("plugin", "value", "message"),
    [
        ("search.area", "0 0 100", "search.area: area '0 0 100' has 3 numbers, but a rectangle "
         'is four, "x_min y_min x_max y_max" (metres); give all four, or the name of an area'),
        ("search.area", "100 0 0 50", "search.area: area '100 0 0 50' is not a rectangle: x_min "
         "must be below x_max"),
        ("track.target", "0 0 1e999 9", "track.target: area '0 0 1e999 9' has a number that is "
         "not finite"),
    ],
)  # fmt: skip
def test_a_malformed_area_is_refused_in_words(plugin: str, value: str, message: str) -> None:
    text = searcher(act(plugin, f'<param key="area" value="{value}"/>'))
    result = check(text, path="s.xml")
    found = at(result.errors, where(text, '<param key="area"'), message)
    assert "pattern" not in found.message and "\\s" not in found.message


def test_a_malformed_route_and_event_name_are_refused_in_words() -> None:
    text = searcher(
        act(
            "formation.arrow",
            '<param key="route" value="0 0; 100"/><param key="event" value="3 go"/>'
            '<param key="offset" value="left"/>',
        )
    )
    result = check(text, path="s.xml")
    at(
        result.errors,
        where(text, '<param key="route"'),
        "formation.arrow: route: waypoint 2 must be two numbers 'x y', not '100'",
    )
    at(
        result.errors,
        where(text, '<param key="event"'),
        "formation.arrow: event must be an event name (a letter or _, then letters, digits",
    )
    at(
        result.errors,
        where(text, '<param key="offset"'),
        "formation.arrow: offset must be two numbers 'forward left' in metres",
    )
    assert not any("pattern" in d.message for d in result.errors)


def test_a_transition_param_is_read_by_the_successors_plugins() -> None:
    text = searcher(
        act("search.area", '<param key="area" value="search"/>'),
        '<param key="area" value="0 0 100"/><param key="TargetPoint" value="anything"/>\n',
    )
    result = check(text, path="s.xml")
    (found,) = result.errors
    place = where(text, '<param key="area" value="0 0')
    assert str(found).startswith(f"s.xml:{place}: ")
    assert found.message.startswith("search.area (in Search): area '0 0 100' has 3 numbers")


def test_an_area_the_world_does_not_have_is_refused_when_the_world_is_given() -> None:
    text = searcher(act("search.area", '<param key="area" value="serch"/>'))
    assert problems(text) == ()  # the world is not known: names are not judged
    found = at(
        check(text, path="s.xml", areas=["field", "search"]).errors,
        where(text, '<param key="area"'),
        "search.area: the world has no area 'serch' (did you mean \"search\"?); its areas are "
        "field, search",
    )
    assert found.severity == "error"
    (none,) = check(text, areas=[]).errors
    assert "it has none" in none.message
    # A rectangle needs no world.
    rect = searcher(act("search.area", '<param key="area" value="0 0 100 50"/>'))
    assert problems(rect, areas=[]) == ()


def test_an_unknown_area_in_a_transition_param_is_refused_too() -> None:
    text = searcher(
        act("search.area", '<param key="area" value="search"/>'),
        '<param key="area" value="feild"/>\n',
    )
    (found,) = check(text, areas=["field", "search"]).errors
    assert "search.area (in Search): the world has no area 'feild'" in found.message


def test_a_plugin_on_a_bus_it_does_not_declare_is_refused() -> None:
    text = searcher(act("detect.target", '<param key="kind" value="jeep"/>'))
    result = check(text, path="s.xml")
    found = at(result.errors, where(text, "detect.target"), "detect.target is written for")
    assert found.message == (
        "detect.target is written for observe_bus (its class declares bus = 'observe_bus'), "
        "not act_bus; move this <Plugin> into the <Bus> of observe_bus"
    )
    # core.idle declares any_bus: it may go anywhere.
    assert problems(searcher(act("core.idle", bus="decide_bus"))) == ()


class Band(Plugin):
    """A plugin whose params are tied together: ``low`` must be below ``high``."""

    any_bus = True
    params: ClassVar[Mapping[str, Param]] = {
        "low": Param(kind="float", required=True),
        "high": Param(kind="float", default=10.0),
    }

    @classmethod
    def check_params(cls, values: Mapping[str, Any]) -> Iterable[tuple[str, str]]:
        if values["low"] >= values["high"]:
            return [("low", f"low must be below high ({values['high']:g}), not {values['low']:g}")]
        return ()

    def step(self, ctx: PluginContext) -> None:
        pass


def test_the_rules_that_tie_params_together_run_at_check_time(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    plugin_class, param_rules = rules.plugin_class, rules.param_rules
    monkeypatch.setattr(
        rules, "plugin_class", lambda name: Band if name == "test.band" else plugin_class(name)
    )
    monkeypatch.setattr(
        rules, "param_rules", lambda name: Band.params if name == "test.band" else param_rules(name)
    )
    known = installed_plugins() | {"test.band"}
    text = searcher(act("test.band", '<param key="low" value="12"/>'))
    (found,) = check(text, path="s.xml", known_plugins=known).errors
    place = where(text, '<param key="low"')
    assert str(found) == f"s.xml:{place}: test.band: low must be below high (10), not 12"
    # With every param read well and the rule kept, nothing is said.
    good = searcher(act("test.band", '<param key="low" value="2"/>'))
    assert check(good, known_plugins=known).diagnostics == ()
