"""Safe parsing of untrusted task-script XML into a small positioned tree.

Task scripts travel from ground stations to every platform, so the parser treats them as
untrusted input:

- the size is capped before anything is parsed (``max_bytes``, default 256 KiB);
- a document type declaration is refused the moment it starts, so no entity can be declared
  (no "billion laughs" expansion) and no DTD, external entity or external subset is ever
  fetched; the entity, notation and external-reference hooks refuse too, as a second wall,
  and parameter-entity parsing is off;
- nesting deeper than :data:`MAX_DEPTH` is refused (the format needs seven levels).

These are the guards ``defusedxml`` installs on expat, plus refusing DTDs outright. The
parser drives ``pyexpat`` directly rather than through ``defusedxml`` because it needs the
byte offset of every start tag (expat's ``CurrentByteIndex``), which the wrapped readers hide:
from that offset it finds each attribute in the raw start tag, so every element *and*
attribute carries its exact ``line:col`` (1-based; columns count characters, a tab is one).

The input is text (``str``) or UTF-8 bytes; it is always parsed as UTF-8 whatever the XML
declaration says, so a declaration cannot make two readers disagree about the content.
Anything the parser refuses raises :class:`XmlError` with a position and an instruction.
"""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass, field
from typing import NoReturn
from xml.parsers import expat

from actorswarm.dsl.model import Position

#: The default size limit of a script, in bytes (UTF-8).
DEFAULT_MAX_BYTES = 256 * 1024
#: The deepest element nesting accepted; the format itself needs seven levels.
MAX_DEPTH = 32


class XmlError(ValueError):
    """The text is not a well-formed, acceptable XML document. ``pos`` says where."""

    def __init__(self, pos: Position, message: str) -> None:
        self.pos = pos
        self.message = message
        super().__init__(f"{pos}: {message}")


@dataclass(frozen=True, slots=True, kw_only=True)
class XmlAttribute:
    """An attribute as written; ``pos`` is the start of its name."""

    name: str
    value: str
    pos: Position


@dataclass(frozen=True, slots=True, kw_only=True)
class XmlElement:
    """An element: its attributes in document order, child elements, and its own text.

    ``text`` joins the element's direct character data (comments and processing
    instructions are dropped); ``text_pos`` is where its first non-blank character is, or
    ``None`` when the element holds only whitespace.
    """

    tag: str
    pos: Position
    attributes: tuple[XmlAttribute, ...] = ()
    children: tuple[XmlElement, ...] = ()
    text: str = ""
    text_pos: Position | None = None

    def attribute(self, name: str) -> XmlAttribute | None:
        """The attribute called ``name``, if written."""
        for attribute in self.attributes:
            if attribute.name == name:
                return attribute
        return None


# Why a friendlier line for some expat errors: expat's wording names the symptom, not the fix.
_HINTS = {
    expat.errors.XML_ERROR_TAG_MISMATCH: "a closing tag does not match the element it closes",
    expat.errors.XML_ERROR_UNDEFINED_ENTITY: (
        "only &lt; &gt; &amp; &quot; &apos; and character references like &#233; are allowed"
    ),
    expat.errors.XML_ERROR_NO_ELEMENTS: "the script ends before its root element is closed",
    expat.errors.XML_ERROR_UNCLOSED_TOKEN: "the script ends inside a tag",
    expat.errors.XML_ERROR_JUNK_AFTER_DOC_ELEMENT: (
        "everything must be inside the one <TaskScript> element"
    ),
    expat.errors.XML_ERROR_INVALID_TOKEN: "a character that cannot appear here, e.g. a bare '<'",
}

# Attributes inside a start tag expat has already accepted as well-formed.
_TAG_NAME = re.compile(rb"<[^\s/>]+")
_ATTRIBUTE = re.compile(rb"\s*([^\s=/>]+)\s*=\s*(?:\"[^\"]*\"|'[^']*')")
_BLANK = b" \t\r\n"
_ENTITY_REF = re.compile(rb"&([A-Za-z_:][A-Za-z0-9_.:\-]*);")
_PREDEFINED = {b"lt", b"gt", b"amp", b"quot", b"apos"}


class _Locator:
    """Turns byte offsets into 1-based ``line:col`` positions (columns in characters)."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.line_starts = [0] + [m.end() for m in re.finditer(rb"\n", data)]

    def position(self, offset: int) -> Position:
        offset = max(0, min(offset, len(self.data)))
        index = bisect.bisect_right(self.line_starts, offset) - 1
        start = self.line_starts[index]
        col = len(self.data[start:offset].decode("utf-8", errors="replace")) + 1
        return Position(index + 1, col)


@dataclass(slots=True)
class _Open:
    """An element being built (children and text still arriving)."""

    tag: str
    pos: Position
    attributes: tuple[XmlAttribute, ...]
    children: list[XmlElement] = field(default_factory=list)
    text: list[str] = field(default_factory=list)
    text_pos: Position | None = None

    def close(self) -> XmlElement:
        return XmlElement(
            tag=self.tag,
            pos=self.pos,
            attributes=self.attributes,
            children=tuple(self.children),
            text="".join(self.text),
            text_pos=self.text_pos,
        )


class _TreeBuilder:
    """Expat callbacks that build the tree and refuse the dangerous parts of XML."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.locate = _Locator(data)
        self.parser = expat.ParserCreate(encoding="UTF-8")
        self.stack: list[_Open] = []
        self.root: XmlElement | None = None
        p = self.parser
        p.ordered_attributes = True
        p.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
        p.StartElementHandler = self.start
        p.EndElementHandler = self.end
        p.CharacterDataHandler = self.characters
        p.StartDoctypeDeclHandler = self.refuse_doctype
        p.EntityDeclHandler = self.refuse_entity
        p.UnparsedEntityDeclHandler = self.refuse_entity
        p.NotationDeclHandler = self.refuse_entity
        p.ExternalEntityRefHandler = self.refuse_external

    def here(self) -> Position:
        return self.locate.position(self.parser.CurrentByteIndex)

    def start(self, tag: str, flat: list[str]) -> None:
        if len(self.stack) >= MAX_DEPTH:
            raise XmlError(
                self.here(),
                f"elements are nested more than {MAX_DEPTH} deep; "
                "a task script needs seven levels at most",
            )
        offset = self.parser.CurrentByteIndex
        found = self._attribute_offsets(offset)
        attributes = tuple(
            XmlAttribute(
                name=name,
                value=value,
                pos=self.locate.position(found.get(name, offset)),
            )
            for name, value in zip(flat[::2], flat[1::2], strict=True)
        )
        self.stack.append(_Open(tag=tag, pos=self.locate.position(offset), attributes=attributes))

    def _attribute_offsets(self, offset: int) -> dict[str, int]:
        """Byte offset of each attribute name in the start tag at ``offset``."""
        found: dict[str, int] = {}
        match = _TAG_NAME.match(self.data, offset)
        at = match.end() if match else offset
        while (m := _ATTRIBUTE.match(self.data, at)) is not None:
            found[m.group(1).decode("utf-8", errors="replace")] = m.start(1)
            at = m.end()
        return found

    def end(self, tag: str) -> None:
        element = self.stack.pop().close()
        if self.stack:
            self.stack[-1].children.append(element)
        else:
            self.root = element

    def characters(self, data: str) -> None:
        if not self.stack:
            return
        current = self.stack[-1]
        current.text.append(data)
        if current.text_pos is None and data.strip():
            # Skip the chunk's leading blanks in the raw bytes to land on the first character.
            at = self.parser.CurrentByteIndex
            while at < len(self.data) and self.data[at] in _BLANK:
                at += 1
            current.text_pos = self.locate.position(at)

    def refuse_doctype(self, *_: object) -> NoReturn:
        # expat calls this after the doctype's name; point at its "<!DOCTYPE" instead.
        offset = self.parser.CurrentByteIndex
        start = self.data.rfind(b"<!DOCTYPE", 0, offset + 1)
        raise XmlError(
            self.locate.position(start if start >= 0 else offset),
            "a DOCTYPE (DTD) is not allowed in a task script: delete the <!DOCTYPE ...> "
            "declaration (entities and external references are refused too)",
        )

    def refuse_entity(self, *_: object) -> NoReturn:
        raise XmlError(self.here(), "entity and notation declarations are not allowed")

    def refuse_external(self, *_: object) -> NoReturn:
        raise XmlError(self.here(), "external entities are not allowed in a task script")


def _as_bytes(source: str | bytes) -> bytes:
    if isinstance(source, str):
        return source.removeprefix("\ufeff").encode("utf-8", errors="surrogatepass")
    data = source.removeprefix(b"\xef\xbb\xbf")
    try:
        data.decode("utf-8")
    except UnicodeDecodeError as exc:
        pos = _Locator(data[: exc.start]).position(exc.start)
        raise XmlError(
            pos, "the script is not valid UTF-8 here; save it as UTF-8 (task scripts are UTF-8)"
        ) from None
    return data


def check_size(size: int, max_bytes: int) -> None:
    """Refuse a script of ``size`` bytes when it is above ``max_bytes``."""
    if size > max_bytes:
        raise XmlError(
            Position(1, 1),
            f"the script is {size} bytes, above the limit of {max_bytes} bytes; "
            "split the task or raise the limit (--max-bytes)",
        )


def parse_xml(source: str | bytes, *, max_bytes: int = DEFAULT_MAX_BYTES) -> XmlElement:
    """Parse ``source`` into its root :class:`XmlElement`, or raise :class:`XmlError`.

    ``str`` input is parsed as is; ``bytes`` must be UTF-8 (a byte-order mark is skipped).
    The size limit applies to the UTF-8 encoding, before any parsing.
    """
    if isinstance(source, bytes):
        check_size(len(source), max_bytes)
    data = _as_bytes(source)
    check_size(len(data), max_bytes)
    builder = _TreeBuilder(data)
    try:
        builder.parser.Parse(data, True)
    except expat.ExpatError as exc:
        message = expat.ErrorString(exc.code) or "malformed XML"
        offset = builder.parser.ErrorByteIndex
        hint = _HINTS.get(message)
        # expat stops just after a '--' inside a comment and calls it an invalid token.
        dashes = offset - 2
        if data.startswith(b"--", dashes) and data.rfind(b"<!--", 0, dashes) > data.rfind(
            b"-->", 0, dashes
        ):
            message, offset = "'--' inside a comment", dashes
            hint = "an XML comment cannot contain two dashes in a row; reword it"
        if message == expat.errors.XML_ERROR_UNDEFINED_ENTITY:
            # expat points at the start of the tag; point at the reference itself.
            for ref in _ENTITY_REF.finditer(data, max(offset, 0)):
                if ref.group(1) not in _PREDEFINED:
                    message = f"undefined entity &{ref.group(1).decode(errors='replace')};"
                    offset = ref.start()
                    break
        pos = builder.locate.position(offset)
        raise XmlError(pos, f"malformed XML: {message}" + (f" ({hint})" if hint else "")) from None
    if builder.root is None:  # pragma: no cover - expat reports "no element found" first
        raise XmlError(Position(1, 1), "the script is empty: it needs a <TaskScript> element")
    return builder.root
