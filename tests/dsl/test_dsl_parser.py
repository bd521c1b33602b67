"""The parser treats scripts as untrusted: no DTD, no entity expansion, no external
resource, a size limit, a depth limit — each refused quickly with a clear, positioned error.
Positions are exact: 1-based lines and columns counted in characters."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from actorswarm.dsl import check, check_file
from actorswarm.dsl.model import Position
from actorswarm.dsl.parser import MAX_DEPTH, XmlError, parse_xml

VALID = (
    '<TaskScript name="t"><_ActorsConfig><Actor><_P_Name>A</_P_Name></Actor></_ActorsConfig>'
    '<_PlatformActorConfig><platform id="1" actor="A"/></_PlatformActorConfig></TaskScript>'
)

BILLION_LAUGHS = """<?xml version="1.0"?>
<!DOCTYPE lolz [
 <!ENTITY lol "lol">
 <!ENTITY lol1 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">
 <!ENTITY lol2 "&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;&lol1;">
 <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">
 <!ENTITY lol4 "&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;&lol3;">
 <!ENTITY lol5 "&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;&lol4;">
 <!ENTITY lol6 "&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;&lol5;">
 <!ENTITY lol7 "&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;&lol6;">
 <!ENTITY lol8 "&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;&lol7;">
 <!ENTITY lol9 "&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;&lol8;">
]>
<TaskScript name="&lol9;"/>
"""

HOSTILE = {
    "billion-laughs": BILLION_LAUGHS,
    "external-entity": (
        '<?xml version="1.0"?>\n<!DOCTYPE t [<!ENTITY x SYSTEM "file:///etc/passwd">]>\n'
        '<TaskScript name="&x;"/>'
    ),
    "external-dtd": (
        '<!DOCTYPE TaskScript SYSTEM "http://127.0.0.1:9/never.dtd">\n<TaskScript name="t"/>'
    ),
    "parameter-entity": (
        '<!DOCTYPE t [<!ENTITY % p SYSTEM "http://127.0.0.1:9/p.dtd"> %p;]>\n<TaskScript/>'
    ),
    "plain-doctype": "<!DOCTYPE TaskScript>\n<TaskScript/>",
}


@pytest.mark.parametrize("text", list(HOSTILE.values()), ids=list(HOSTILE))
def test_dtds_and_entities_are_refused_quickly(text: str) -> None:
    start = time.perf_counter()
    result = check(text, path="evil.xml", known_plugins=set())
    elapsed = time.perf_counter() - start
    assert elapsed < 0.5
    line = text[: text.index("<!DOCTYPE")].count("\n") + 1
    assert [str(d) for d in result.errors] == [
        f"evil.xml:{line}:1: a DOCTYPE (DTD) is not allowed in a "
        "task script: delete the <!DOCTYPE ...> declaration (entities and external references "
        "are refused too)"
    ]


def test_an_entity_without_a_dtd_is_an_undefined_entity() -> None:
    result = check('<TaskScript name="&passwd;"/>', known_plugins=set())
    assert result.errors[0].message.startswith("malformed XML: undefined entity &passwd;")
    assert (result.errors[0].line, result.errors[0].col) == (1, 19)


def test_predefined_entities_and_character_references_are_read() -> None:
    root = parse_xml('<TaskScript name="a &amp; b &#233; &lt;c&gt;"/>')
    attribute = root.attribute("name")
    assert attribute is not None and attribute.value == "a & b é <c>"


def test_oversized_input_is_refused_before_parsing() -> None:
    big = VALID.replace("</TaskScript>", "<!--" + "x" * 300_000 + "--></TaskScript>")
    start = time.perf_counter()
    result = check(big, path="big.xml", known_plugins={"core.idle"})
    assert time.perf_counter() - start < 0.5
    (error,) = result.errors
    assert (error.line, error.col) == (1, 1)
    assert "above the limit of 262144 bytes" in error.message
    assert check(big, known_plugins={"core.idle"}, max_bytes=1 << 20).ok


def test_an_oversized_file_is_refused_unread(tmp_path: Path) -> None:
    path = tmp_path / "big.xml"
    data = b" " * 2000 + VALID.encode()
    path.write_bytes(data)
    result = check_file(path, max_bytes=1000)
    assert [e.message.split(";")[0] for e in result.errors] == [
        f"the script is {len(data)} bytes, above the limit of 1000 bytes"
    ]


def test_deep_nesting_is_refused() -> None:
    text = "<a>" * (MAX_DEPTH + 1) + "</a>" * (MAX_DEPTH + 1)
    with pytest.raises(XmlError, match="nested more than 32 deep") as caught:
        parse_xml(text)
    assert caught.value.pos == Position(1, 3 * MAX_DEPTH + 1)


def test_bytes_must_be_utf8() -> None:
    result = check(b'<TaskScript name="caf\xe9"/>', path="latin1.xml", known_plugins=set())
    assert str(result.errors[0]).startswith("latin1.xml:1:22: the script is not valid UTF-8")


def test_the_declared_encoding_does_not_change_how_text_is_read() -> None:
    text = '<?xml version="1.0" encoding="ISO-8859-1"?>\n<TaskScript name="café"/>'
    attribute = parse_xml(text.encode("utf-8")).attribute("name")
    assert attribute is not None and attribute.value == "café"


def test_a_byte_order_mark_is_skipped() -> None:
    root = parse_xml(b"\xef\xbb\xbf<TaskScript name='t'/>")
    assert root.pos == Position(1, 1)


def test_positions_count_characters_and_follow_lines() -> None:
    text = (
        '<TaskScript name="é">\r\n'
        '\t<_ActorsConfig\n      note="x"   other = "y"/>\n'
        "  <_TaskConfig>  text here </_TaskConfig>\n"
        "</TaskScript>"
    )
    root = parse_xml(text)
    actors, task = root.children
    assert root.pos == Position(1, 1)
    assert actors.pos == Position(2, 2)
    assert [(a.name, a.pos) for a in actors.attributes] == [
        ("note", Position(3, 7)),
        ("other", Position(3, 18)),
    ]
    assert task.text_pos == Position(4, 18) and task.text.strip() == "text here"


def test_malformed_xml_reports_line_and_column() -> None:
    result = check("<TaskScript name='t'>\n  <Actor>\n</TaskScript>", path="m.xml")
    assert str(result.errors[0]).startswith("m.xml:3:3: malformed XML: mismatched tag")


def test_comments_and_processing_instructions_are_ignored() -> None:
    text = "<?actorswarm sim x.xml --no-world?>\n<!-- a note -->\n" + VALID
    assert check(text, known_plugins={"core.idle"}).ok
