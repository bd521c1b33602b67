"""Task scripts (docs/design.md §4): the XML that programs a swarm as an Actor state machine.

Check a script and read its diagnostics, or load it as a typed model for the task engine::

    from actorswarm.dsl import check, load

    result = check(text, path="mission.xml")
    for diagnostic in result.diagnostics:
        print(diagnostic)            # mission.xml:12:7: unknown actor ...
    script = load("mission.xml")     # a TaskScript, or ScriptError with every diagnostic

:func:`to_mermaid` and :func:`to_dot` draw the state machine; :func:`to_xml` writes a model
back in the canonical form; :func:`schema_path` is the XSD for editors. The format and every
check are described in ``docs/task-scripts.md``.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from actorswarm.dsl.checker import CheckResult, check, check_file, load
    from actorswarm.dsl.diagnostics import Diagnostic, ScriptError
    from actorswarm.dsl.graph import Edge, state_edges, to_dot, to_mermaid
    from actorswarm.dsl.model import (
        BUSES,
        Actor,
        Branch,
        BusName,
        Count,
        Param,
        PlatformLine,
        PluginSpec,
        Position,
        SysNum,
        TaskScript,
        Transition,
    )
    from actorswarm.dsl.parser import DEFAULT_MAX_BYTES
    from actorswarm.dsl.plugins import BUILTIN_PLUGINS, ENTRY_POINT_GROUP, installed_plugins
    from actorswarm.dsl.writer import to_xml

#: Where each name of ``__all__`` lives. They are imported on first use (PEP 562), not with
#: the package: the daemon needs only :mod:`.model` until a script is deployed, and the
#: checker, the writer (``xml.sax.saxutils`` pulls in ``urllib``, ``http`` and ``ssl``) and
#: the plugin listing would otherwise load with any ``actorswarm.dsl.*`` module.
_WHERE = {
    **dict.fromkeys(("CheckResult", "check", "check_file", "load"), "checker"),
    **dict.fromkeys(("Diagnostic", "ScriptError"), "diagnostics"),
    **dict.fromkeys(("Edge", "state_edges", "to_dot", "to_mermaid"), "graph"),
    **dict.fromkeys(
        (
            "BUSES",
            "Actor",
            "Branch",
            "BusName",
            "Count",
            "Param",
            "PlatformLine",
            "PluginSpec",
            "Position",
            "SysNum",
            "TaskScript",
            "Transition",
        ),
        "model",
    ),
    "DEFAULT_MAX_BYTES": "parser",
    **dict.fromkeys(("BUILTIN_PLUGINS", "ENTRY_POINT_GROUP", "installed_plugins"), "plugins"),
    "to_xml": "writer",
}


def __getattr__(name: str) -> object:
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{where}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_WHERE})


def schema_path() -> Path:
    """Where the installed ``schema.xsd`` of the format is (an XSD 1.0 schema for editors)."""
    return Path(__file__).with_name("schema.xsd")


__all__ = [
    "BUILTIN_PLUGINS",
    "BUSES",
    "DEFAULT_MAX_BYTES",
    "ENTRY_POINT_GROUP",
    "Actor",
    "Branch",
    "BusName",
    "CheckResult",
    "Count",
    "Diagnostic",
    "Edge",
    "Param",
    "PlatformLine",
    "PluginSpec",
    "Position",
    "ScriptError",
    "SysNum",
    "TaskScript",
    "Transition",
    "check",
    "check_file",
    "installed_plugins",
    "load",
    "schema_path",
    "state_edges",
    "to_dot",
    "to_mermaid",
    "to_xml",
]
