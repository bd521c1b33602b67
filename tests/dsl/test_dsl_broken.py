"""A table of broken task scripts: each is refused, at the exact line:col, with a message
that says what is wrong. Warnings get a table of their own; they never refuse a script.

Every script is :data:`BASE` with one or two lines replaced (one-line replacements keep the
line numbers of the others), so the expected positions can be read off the case itself.
"""

from __future__ import annotations

import pytest

from actorswarm.dsl import check

PLUGINS = frozenset({"core.idle", "core.emit_after", "formation.arrow"})

BASE = {
    1: '<TaskScript name="t" version="1">',
    2: "<_ActorsConfig>",
    3: "  <Actor><_P_Name>A</_P_Name></Actor>",
    4: "  <Actor><_P_Name>B</_P_Name></Actor>",
    5: "</_ActorsConfig>",
    6: "<_TaskConfig>",
    7: '  <actor name="A"><transition name="go" sysNum="2"><successor actor="B"/></transition>'
    "</actor>",
    8: "</_TaskConfig>",
    9: "<_PlatformActorConfig>",
    10: '  <platform id="1-2" actor="A"/>',
    11: "</_PlatformActorConfig>",
    12: "</TaskScript>",
}


def make(lines: dict[int, str] | None = None) -> str:
    merged = BASE | (lines or {})
    return "\n".join(merged[i] for i in sorted(merged))


def a_go(attrs: str, body: str = '<successor actor="B"/>', name: str = "go") -> str:
    """Line 7: actor A with one transition (``<transition name="go" `` is at column 19)."""
    return f'  <actor name="A"><transition name="{name}" {attrs}>{body}</transition></actor>'


def branch(cnt: str, to: str = "B") -> str:
    return f'<branch cnt="{cnt}"><successor actor="{to}"/></branch>'


def with_plugin(name: str, params: str = "") -> str:
    """Line 3: actor A with one plugin on act_bus (its name's text is at column 90)."""
    return (
        "  <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bus</_P_Name>"
        f"<Plugin><_P_Name>{name}</_P_Name>{params}</Plugin></Bus></OODAConfig></Actor>"
    )


EMIT = '<param key="event" value="go"/><param key="after" value="1"/>'
BC = "  <Actor><_P_Name>B</_P_Name></Actor><Actor><_P_Name>C</_P_Name></Actor>"
MERGE_5 = (
    '  <actor name="B"><transition name="fin" barrierKey="5" sysNum="2">'
    '<successor actor="A"/></transition></actor>'
    '<actor name="C"><transition name="fin" barrierKey="5" sysNum="{c}">'
    '<successor actor="A"/></transition></actor>{more}'
)
# A splits into the B's and C's that merge in group 5.
A_SPLITS = (
    '<actor name="A"><transition name="go" sysNum="5">'
    + branch("1")
    + branch("4", "C")
    + "</transition></actor>"
)

# (id, script, "line:col", a piece of the message)
# fmt: off
ERRORS: list[tuple[str, str, str, str]] = [
    # --- not XML, or not a task script
    ("mismatched-tag", make({7: a_go('sysNum="2"').replace("</transition>", "</transitio>")}),
     "7:76", "mismatched tag"),
    ("empty", "", "1:1", "no element found"),
    ("undefined-entity", make({1: '<TaskScript name="&t;">'}), "1:19", "undefined entity &t;"),
    ("junk-after-root", make() + "\n<more/>", "13:1", "inside the one <TaskScript>"),
    ("dashes-in-comment", "<!-- run --no-world -->\n" + make(), "1:10", "'--' inside a comment"),
    ("root", make({1: '<Taskscript name="t">', 12: "</Taskscript>"}), "1:1", 'mean "TaskScript"'),
    # --- structure: elements and attributes
    ("unknown-element", make({3: "  <Actor><_P_Nme>A</_P_Nme></Actor>"}),
     "3:10", 'unknown element <_P_Nme> inside <Actor> (did you mean "_P_Name"?)'),
    ("unknown-attribute", make({7: a_go('sysnum="2"')}),
     "7:41", 'no attribute "sysnum" (did you mean "sysNum"?)'),
    ("unknown-platform-attribute", make({10: '  <platform ids="1-2" actor="A"/>'}),
     "10:13", '(did you mean "id"?)'),
    ("misplaced-element", make({3: "  <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bus"
                                   "</_P_Name><_P_ID>3</_P_ID></Bus></OODAConfig></Actor>"}),
     "3:73", "<_P_ID> does not belong inside <Bus>; it goes in <Actor>"),
    ("script-name-missing", make({1: '<TaskScript version="1">'}),
     "1:1", "<TaskScript> needs a name attribute"),
    ("actor-name-missing", make({4: "  <Actor><_P_ID>2</_P_ID></Actor>"}),
     "4:3", "<Actor> needs a <_P_Name>"),
    ("transition-name-missing", make({7: a_go('sysNum="2"').replace('name="go" ', "")}),
     "7:19", "<transition> needs a name attribute"),
    ("sysnum-missing", make({7: a_go("")}), "7:19", "needs a sysNum attribute"),
    ("text-in-actor", make({3: "  <Actor>junk<_P_Name>A</_P_Name></Actor>"}),
     "3:10", "text 'junk' is not allowed inside <Actor>"),
    ("two-names", make({3: "  <Actor><_P_Name>A</_P_Name><_P_Name>C</_P_Name></Actor>"}),
     "3:30", "<Actor> takes one <_P_Name>"),
    ("successor-and-branch",
     make({7: a_go('sysNum="2"', '<successor actor="B"/>' + branch("2"))}),
     "7:74", "either one <successor>"),
    ("no-successor", make({7: a_go('sysNum="2"', "")}), "7:19", "<transition> needs a successor"),
    ("no-platform-line", make({10: ""}), "9:1", "<_PlatformActorConfig> needs a <platform>"),
    # --- values
    ("actor-name-syntax", make({3: "  <Actor><_P_Name>my actor</_P_Name></Actor>"}),
     "3:19", "'my actor' is not a valid name"),
    ("actor-id-junk", make({3: "  <Actor><_P_Name>A</_P_Name><_P_ID>x</_P_ID></Actor>"}),
     "3:37", "_P_ID (the actor ID) must be an integer from 1 to 65535"),
    ("priority-range", make({3: "  <Actor><_P_Name>A</_P_Name><_P_Prio>300</_P_Prio></Actor>"}),
     "3:39", "must be an integer from 0 to 255, not '300'"),
    ("unknown-bus", make({3: "  <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bs"
                             "</_P_Name></Bus></OODAConfig></Actor>"}),
     "3:56", "unknown bus 'act_bs' (did you mean \"act_bus\"?)"),
    ("bus-twice", make({3: "  <Actor><_P_Name>A</_P_Name><OODAConfig><Bus><_P_Name>act_bus"
                           "</_P_Name></Bus><Bus><_P_Name>act_bus</_P_Name></Bus></OODAConfig>"
                           "</Actor>"}),
     "3:93", "already configures act_bus at 3:56"),
    ("barrier-key-64", make({7: a_go('sysNum="2" barrierKey="64"')}),
     "7:52", "barrierKey must be an integer from 1 to 63, not '64'"),
    ("barrier-key-junk", make({7: a_go('sysNum="2" barrierKey="abc"')}),
     "7:52", "barrierKey must be an integer"),
    ("sysnum-zero", make({7: a_go('sysNum="0"')}), "7:41", "sysNum must be a positive integer"),
    ("sysnum-word", make({7: a_go('sysNum="some"')}), "7:41", "or \"all\", not 'some'"),
    ("cnt-zero", make({7: a_go('sysNum="2"', branch("0"))}),
     "7:60", 'cnt must be a positive integer or "rest"'),
    ("cnt-word", make({7: a_go('sysNum="2"', branch("many"))}), "7:60", "not 'many'"),
    ("timeout-negative", make({7: a_go('sysNum="2" timeout="-5"')}),
     "7:52", "timeout must be a positive number of seconds"),
    ("timeout-word", make({7: a_go('sysNum="2" timeout="soon"')}),
     "7:52", "timeout must be a number"),
    ("platform-range-down", make({10: '  <platform id="5-1" actor="A"/>'}),
     "10:13", "the range '5-1' goes down; write it as 1-5"),
    ("platform-zero", make({10: '  <platform id="0" actor="A"/>'}),
     "10:13", "platform ID 0 is out of range"),
    ("platform-too-big", make({10: '  <platform id="1,70000" actor="A"/>'}),
     "10:13", "platform ID 70000 is out of range: IDs go from 1 to 65535"),
    ("platform-junk", make({10: '  <platform id="1,x" actor="A"/>'}),
     "10:13", "'x' in the platform list is not an ID or a range"),
    ("platform-listed-twice", make({10: '  <platform id="1-3,2" actor="A"/>'}),
     "10:13", "platform 2 is listed twice"),
    ("names-and-params", make({3: with_plugin("core.idle</_P_Name><_P_Name>core.idle",
                                              '<param key="a" value="1"/>')}),
     "3:137", "this <Plugin> lists 2 plugins"),
    ("param-key-empty",
     make({7: a_go('sysNum="2"', '<param key=" " value="1"/><successor actor="B"/>')}),
     "7:59", "needs a non-empty key"),
    ("param-twice", make({7: a_go('sysNum="2"', '<param key="k" value="1"/><param key="k" '
                                                'value="2"/><successor actor="B"/>')}),
     "7:85", "param 'k' is already set at 7:59"),
    ("plugin-path", make({3: with_plugin("pkg.mod:")}),
     "3:90", "must read package.module:ClassName"),
    # --- names and references
    ("actor-twice", make({4: "  <Actor><_P_Name>A</_P_Name></Actor>"}),
     "4:19", "actor A is already defined at 3:19"),
    ("actor-id-twice", make({3: "  <Actor><_P_Name>A</_P_Name><_P_ID>4</_P_ID></Actor>",
                             4: "  <Actor><_P_Name>B</_P_Name><_P_ID>4</_P_ID></Actor>"}),
     "4:37", "actor ID 4 is already used by actor A at 3:37"),
    ("transitions-of-unknown-actor",
     make({7: a_go('sysNum="2"').replace('actor name="A"', 'actor name="a"')}),
     "7:10", 'actor a, which is not defined (did you mean "A"?)'),
    ("unknown-successor", make({7: a_go('sysNum="2"', '<successor actor="D"/>')}),
     "7:63", "the successor D is not a defined actor"),
    ("unknown-timeout-branch", make({7: a_go('sysNum="2" timeout="5" timeoutBranch="C"')}),
     "7:64", "timeoutBranch C is not a defined actor"),
    ("unknown-platform-actor", make({10: '  <platform id="1-2" actor="b"/>'}),
     "10:22", 'start actor b, which is not defined (did you mean "B"?)'),
    ("unknown-plugin", make({3: with_plugin("core.idel")}),
     "3:90", "plugin 'core.idel' is not installed (did you mean \"core.idle\"?)"),
    # --- the params of the built-in plugins
    ("emit-after-no-event",
     make({3: with_plugin("core.emit_after", '<param key="after" value="1"/>')}),
     "3:90", "core.emit_after needs the param event"),
    ("emit-after-unknown-param",
     make({3: with_plugin("core.emit_after", '<param key="event" value="go"/>'
                                             '<param key="delay" value="1"/>')}),
     "3:146", "core.emit_after has no param 'delay'"),
    ("emit-after-negative", make({3: with_plugin("core.emit_after", '<param key="event" '
                                                 'value="go"/><param key="after" value="-1"/>')}),
     "3:146", "after must be ≥ 0"),
    ("emit-after-scope",
     make({3: with_plugin("core.emit_after", EMIT + '<param key="scope" value="global"/>')}),
     "3:176", 'scope must be one of "local", "swarm"'),
    ("emit-after-spread", make({3: with_plugin("core.emit_after", EMIT + '<param key='
                                               '"spread_per_platform" value="fast"/>')}),
     "3:176", "spread_per_platform must be a number"),
    ("emit-after-typo",
     make({3: with_plugin("core.emit_after", EMIT + '<param key="evnt" value="x"/>')}),
     "3:176", "no param 'evnt' (did you mean \"event\"?)"),
    ("idle-takes-no-params", make({3: with_plugin("core.idle", '<param key="x" value="1"/>')}),
     "3:109", "core.idle has no param 'x'; it takes no params"),
    # --- transitions
    ("transition-twice", make({7: a_go('sysNum="2"').replace("</actor>", "") + '<transition name='
                                  '"go" sysNum="1"><successor actor="B"/></transition></actor>'}),
     "7:99", "actor A already has a transition for go at 7:31"),
    ("actor-block-twice", make({7: a_go('sysNum="2"') + '<actor name="A"><transition name="x" '
                                   'sysNum="1"><successor actor="B"/></transition></actor>'}),
     "7:95", "actor A already has an <actor> block at 7:10"),
    ("counts-short", make({7: a_go('sysNum="2"', branch("1"))}),
     "7:41", "the branch counts add up to 1 but sysNum is 2"),
    ("counts-over", make({7: a_go('sysNum="2"', branch("2") + branch("1"))}),
     "7:41", "add up to 3, more than sysNum 2"),
    ("counts-over-with-rest", make({7: a_go('sysNum="2"', branch("3") + branch("rest"))}),
     "7:41", "add up to 3, more than sysNum 2"),
    ("two-rests", make({7: a_go('sysNum="2"', branch("rest") + branch("rest"))}),
     "7:102", 'at most one cnt="rest" branch'),
    ("all-without-rest", make({7: a_go('sysNum="all"', branch("1") + branch("1"))}),
     "7:41", 'with sysNum="all"'),
    # --- platforms and barrier groups
    ("platform-starts-twice",
     make({10: '  <platform id="1-2" actor="A"/><platform id="2-3" actor="A"/>'}),
     "10:43", "platform 2 already starts actor A at 10:13"),
    ("more-than-platforms", make({7: a_go('sysNum="3"')}),
     "7:19", "transition go of actor A can never fire: it needs 3 platforms running A at once, "
             "but only 2"),
    ("group-one-actor-short",
     make({4: BC, 7: MERGE_5.format(c=8, more=""),
           10: '  <platform id="1-5" actor="B"/><platform id="6-10" actor="C"/>'}),
     "7:19", "barrier group 5 can never fire: it needs 8 platforms running C at once"),
    ("group-2B-8C-on-5-platforms",
     make({4: BC, 7: MERGE_5.format(c=8, more=A_SPLITS), 10: '  <platform id="1-5" actor="A"/>'}),
     "7:19", "it needs 8 platforms running C at once (for fin of C), but only 5 can ever run it"),
    ("group-2B-4C-on-5-platforms",
     make({4: BC, 7: MERGE_5.format(c=4, more=A_SPLITS), 10: '  <platform id="1-5" actor="A"/>'}),
     "7:57", "barrier group 5 can never fire: it needs 2 platforms running B at once (for fin "
             "of B), but the branch counts of the transitions that lead to it let at most 1"),
]

WARNINGS: list[tuple[str, str, str, str]] = [
    ("timeout-branch-without-timeout", make({7: a_go('sysNum="2" timeoutBranch="B"')}),
     "7:52", "timeoutBranch has no effect without a timeout"),
    ("never-runs", make({4: BC}), "4:38", "no platform ever runs actor C"),
    ("rest-gets-nothing", make({7: a_go('sysNum="2"', branch("2") + branch("rest"))}),
     "7:99", 'this cnt="rest" branch never gets a participant'),
    ("emitted-but-unhandled", make({3: with_plugin("core.emit_after", '<param key="event" '
                                                   'value="og"/><param key="after" value="1"/>')}),
     "3:115", "core.emit_after emits og, but no transition handles it"),
    ("lost-typo", make({7: a_go('sysNum="1"', name="Aa_lost")}),
     "7:31", 'there is no actor Aa (did you mean "A"?)'),
    # Its transition of B has no candidates while the group waits: the group fires without.
    ("group-that-feeds-itself",
     make({7: a_go('barrierKey="2" sysNum="2"') + '<actor name="B"><transition name="back" '
              'barrierKey="2" sysNum="1"><successor actor="A"/></transition></actor>'}),
     "7:126", "back of B never takes part in barrier group 2: B is only entered through this "
              "group itself"),
]
# fmt: on


def _show(found: object) -> str:
    return "\n".join(str(d) for d in found)  # type: ignore[attr-defined]


def test_the_base_script_is_valid() -> None:
    result = check(make(), path="s.xml", known_plugins=PLUGINS)
    assert result.ok and not result.warnings, _show(result.diagnostics)


def test_the_table_is_large_enough() -> None:
    assert len(ERRORS) >= 35
    assert len({case[0] for case in ERRORS + WARNINGS}) == len(ERRORS) + len(WARNINGS)


@pytest.mark.parametrize(
    ("text", "where", "message"), [pytest.param(*case[1:], id=case[0]) for case in ERRORS]
)
def test_broken_script_is_refused_at_the_place(text: str, where: str, message: str) -> None:
    result = check(text, path="s.xml", known_plugins=PLUGINS)
    assert not result.ok and result.script is None
    hits = [d for d in result.errors if f"{d.line}:{d.col}" == where and message in d.message]
    assert hits, f"expected s.xml:{where}: ...{message}..., got:\n{_show(result.errors)}"
    assert str(hits[0]).startswith(f"s.xml:{where}: ")


@pytest.mark.parametrize(
    ("text", "where", "message"), [pytest.param(*case[1:], id=case[0]) for case in WARNINGS]
)
def test_warning_is_given_but_the_script_is_accepted(text: str, where: str, message: str) -> None:
    result = check(text, path="s.xml", known_plugins=PLUGINS)
    assert result.ok and result.script is not None, _show(result.errors)
    hits = [d for d in result.warnings if f"{d.line}:{d.col}" == where and message in d.message]
    assert hits, f"expected s.xml:{where}: warning: {message}, got:\n{_show(result.warnings)}"
    assert str(hits[0]).startswith(f"s.xml:{where}: warning: ")


def test_a_broken_actor_does_not_make_its_references_errors_too() -> None:
    # The actor's name is misspelled as an element: one real error, not "unknown actor A"
    # at every place that names it.
    result = check(
        make({3: "  <Actor><_P_Nme>A</_P_Nme></Actor>"}), path="s.xml", known_plugins=PLUGINS
    )
    assert not any("not defined" in d.message for d in result.errors), _show(result.errors)


def test_many_errors_are_reported_in_one_pass_in_script_order() -> None:
    text = make(
        {
            3: "  <Actor><_P_Name>A</_P_Name><_P_Prio>x</_P_Prio></Actor>",
            7: a_go('sysNum="0"'),
            10: '  <platform id="1-2" actor="D"/>',
        }
    )
    result = check(text, path="s.xml", known_plugins=PLUGINS)
    assert [(d.line, d.col) for d in result.errors] == [(3, 39), (7, 41), (10, 22)]


def test_schema_attributes_on_the_root_are_accepted() -> None:
    head = (
        '<TaskScript xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
        'xsi:noNamespaceSchemaLocation="schema.xsd" name="t">'
    )
    result = check(make({1: head}), known_plugins=PLUGINS)
    assert result.ok, _show(result.errors)
