"""The XSD shipped for editors: a valid XSD 1.0 schema, in the package, that accepts every
example and the canonical form, and that declares exactly the grammar the checker enforces."""

from __future__ import annotations

from pathlib import Path

import pytest
import xmlschema

from actorswarm.dsl import check, installed_plugins, load, schema_path, to_xml
from actorswarm.dsl.builder import GRAMMAR

PLUGINS = installed_plugins()  # every example must check on this machine


@pytest.fixture(scope="module")
def schema() -> xmlschema.XMLSchema10:
    return xmlschema.XMLSchema10(str(schema_path()))


def test_the_schema_is_installed_with_the_package() -> None:
    path = schema_path()
    assert path.is_file() and path.name == "schema.xsd"
    assert path.parent.name == "dsl"


def test_every_example_passes_the_schema_and_the_checker(
    schema: xmlschema.XMLSchema10, example: Path
) -> None:
    schema.validate(str(example))
    assert check(example.read_bytes(), known_plugins=PLUGINS).ok


def test_the_canonical_form_passes_the_schema(schema: xmlschema.XMLSchema10, example: Path) -> None:
    schema.validate(to_xml(load(example, known_plugins=PLUGINS)))


def test_the_schema_accepts_sections_and_children_in_any_order(
    schema: xmlschema.XMLSchema10,
) -> None:
    text = """<TaskScript name="t">
      <_PlatformActorConfig><platform id="1, 2 - 3" actor="A"/></_PlatformActorConfig>
      <_ActorsConfig><Actor><_P_Prio>3</_P_Prio><_P_Name>A</_P_Name><OODAConfig><Bus>
        <Plugin><param key="k" value="v"/><_P_Name>core.idle</_P_Name></Plugin>
        <_P_Name>act_bus</_P_Name></Bus></OODAConfig></Actor></_ActorsConfig>
    </TaskScript>"""
    schema.validate(text)


def test_the_schema_refuses_what_it_can_see(schema: xmlschema.XMLSchema10) -> None:
    base = (
        '<TaskScript name="t"><_ActorsConfig><Actor><_P_Name>A</_P_Name></Actor>'
        "</_ActorsConfig><_TaskConfig>{}</_TaskConfig><_PlatformActorConfig>"
        '<platform id="1-2" actor="A"/></_PlatformActorConfig></TaskScript>'
    )
    ok = (
        '<actor name="A"><transition name="go" sysNum="2"><successor actor="A"/>'
        "</transition></actor>"
    )
    assert schema.is_valid(base.format(ok))
    for bad in [
        'sysNum="2" barrierKey="64"',
        'sysNum="some"',
        'sysNum="2" timeout="-1"',
        'sysnum="2"',
    ]:
        assert not schema.is_valid(base.format(ok.replace('sysNum="2"', bad)))


def _declared(schema: xmlschema.XMLSchema10) -> dict[str, tuple[set[str], set[str], set[str]]]:
    """``{tag: (required attributes, optional attributes, child tags)}`` over all contexts."""
    found: dict[str, tuple[set[str], set[str], set[str]]] = {}
    todo = [schema.elements["TaskScript"]]
    seen: set[tuple[str, int]] = set()
    while todo:
        element = todo.pop()
        if (element.name, id(element.type)) in seen:
            continue
        seen.add((element.name, id(element.type)))
        required, optional, children = found.setdefault(element.name, (set(), set(), set()))
        for name, attribute in element.attributes.items():
            (required if attribute.use == "required" else optional).add(name)
        for child in element.iterchildren():
            children.add(child.name)
            todo.append(child)
    return found


def test_the_schema_declares_the_checkers_grammar(schema: xmlschema.XMLSchema10) -> None:
    declared = _declared(schema)
    assert set(declared) == set(GRAMMAR)
    for tag, shape in GRAMMAR.items():
        required, optional, children = declared[tag]
        assert required == set(shape.required), tag
        assert optional == set(shape.optional), tag
        assert children == set(shape.children), tag
