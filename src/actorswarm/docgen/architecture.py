"""The architecture pictures of docs/design.md, drawn from the code itself.

Pictures between ``<!-- architecture:begin -->`` and ``<!-- architecture:end -->``:

- **the packages and their imports**: an arrow ``a --> b`` when a module of package ``a``
  imports one of ``b`` at run time (imports under ``if TYPE_CHECKING:`` are not
  dependencies); arrows implied by a longer path are left out, so the picture stays
  readable while every dependency remains reachable along the arrows;
- **the parts of a platform's** :class:`~actorswarm.core.node.Node`: its class chain (each
  class with its length in lines) and the objects each class creates and keeps
  (``self.x = Part(...)``), named by attribute; the parts of the node's own package
  (``actorswarm.core.node``) are drawn with their length and their own parts too;
- **the collective core's folders**: each module of ``core/`` and of its part folders, with
  its length and the first line of its docstring.
- **a packet's way in and out**: each method of
  :class:`~actorswarm.security.pipeline.Pipeline` and what it calls on its parts (``guard``,
  ``endpoint``, ``transport``) or on itself, read from its source; and every class the
  pipeline serves (a class of the package with a ``receive_packet``) with its ways in
  (public methods that take a packet: a ``Packet``, or bytes to a ``receive…``) and its ways
  out (public methods that return a ``Ready`` or ``Outgoing`` packets). A second door either
  way shows in the picture.

::

    python -m actorswarm.docgen.architecture           # print the block
    python -m actorswarm.docgen.architecture --write   # rewrite the block in the document
    python -m actorswarm.docgen.architecture --check   # exit 1 with a diff if it is stale
"""

from __future__ import annotations

import ast
import importlib
import inspect
import re
import sys
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Final

from actorswarm.docgen.block import GeneratedBlock

BEGIN: Final = "<!-- architecture:begin -->"
END: Final = "<!-- architecture:end -->"
COMMAND: Final = "python -m actorswarm.docgen.architecture --write"
#: The package's source folder, and docs/design.md of the tree it belongs to.
PACKAGE: Final = Path(__file__).resolve().parents[1]
DOC: Final = PACKAGE.parents[1] / "docs" / "design.md"
#: Tooling that reads the layers and is no layer itself.
LEFT_OUT: Final = frozenset({"docgen"})


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """The ids of every node under an ``if TYPE_CHECKING:`` block."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            inside.update(id(child) for child in ast.walk(node))
    return inside


def _imported(tree: ast.AST) -> Iterator[str]:
    """The absolute module names ``tree`` imports at run time."""
    skip = _type_checking_nodes(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module
        elif isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)


def package_imports(root: Path = PACKAGE) -> dict[str, set[str]]:
    """Package → the other packages of ``root`` its modules import at run time (modules at
    the top of ``root`` count as packages of their own name)."""
    graph: dict[str, set[str]] = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).parts
        package = parts[0] if len(parts) > 1 else path.stem
        if package in LEFT_OUT or package in {"__init__", "__main__"}:
            continue
        deps = graph.setdefault(package, set())
        for module in _imported(ast.parse(path.read_text(encoding="utf-8"))):
            names = module.split(".")
            inside = names[0] == root.name and len(names) > 1
            if inside and names[1] != package and names[1] not in LEFT_OUT:
                deps.add(names[1])
    return graph


def _reachable(graph: Mapping[str, set[str]], start: str) -> set[str]:
    seen: set[str] = set()
    todo = list(graph.get(start, ()))
    while todo:
        node = todo.pop()
        if node not in seen:
            seen.add(node)
            todo.extend(graph.get(node, ()))
    return seen


def reduced(graph: Mapping[str, set[str]]) -> dict[str, set[str]]:
    """``graph`` without the arrows that a longer path implies (its transitive reduction,
    where it has no cycle; an arrow on a cycle is kept)."""
    out: dict[str, set[str]] = {}
    for node, deps in graph.items():
        keep = set()
        for dep in deps:
            via_other = any(
                dep in _reachable(graph, other) and node not in _reachable(graph, other)
                for other in deps - {dep}
            )
            if not via_other:
                keep.add(dep)
        out[node] = keep
    return out


def packages_diagram(root: Path = PACKAGE) -> list[str]:
    graph = reduced(package_imports(root))
    lines = ["```mermaid", "flowchart TD"]
    for node in sorted(graph):
        lines.extend(f"    {node} --> {dep}" for dep in sorted(graph[node]))
    lines.append("```")
    return lines


def _on_self(target: ast.expr) -> bool:
    """Whether ``target`` is ``self.<name>``."""
    return (
        isinstance(target, ast.Attribute)
        and isinstance(target.value, ast.Name)
        and target.value.id == "self"
    )


def _parts(cls: type) -> dict[str, type]:
    """Attribute → class name of what ``cls``'s own methods create and keep
    (``self.x = Part(...)``, also as one arm of a conditional expression)."""
    module = sys.modules[cls.__module__]
    found: dict[str, type] = {}
    for node in ast.walk(ast.parse(inspect.getsource(cls))):
        if not isinstance(node, ast.Assign | ast.AnnAssign) or node.value is None:
            continue
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        values = (
            [node.value.body, node.value.orelse]
            if isinstance(node.value, ast.IfExp)
            else [node.value]
        )
        for value in values:
            if not (isinstance(value, ast.Call) and isinstance(value.func, ast.Name)):
                continue
            made = getattr(module, value.func.id, None)
            if not (inspect.isclass(made) and made.__module__.startswith("actorswarm.")):
                continue
            for target in targets:
                if _on_self(target):
                    assert isinstance(target, ast.Attribute)
                    found.setdefault(target.attr, made)
    return found


def node_diagram(qualified: str = "actorswarm.core.node:Node") -> list[str]:
    module_name, _, name = qualified.partition(":")
    top: type = getattr(importlib.import_module(module_name), name)
    chain = [c for c in top.__mro__ if c.__module__.startswith("actorswarm.")]
    # The package the node's own parts live in (``actorswarm.core.node``).
    home = top.__module__.rpartition(".")[0] + "."
    lines = ["```mermaid", "classDiagram"]

    def declare(cls: type) -> None:
        length = len(inspect.getsource(cls).splitlines())
        module = cls.__module__.removeprefix("actorswarm.")
        lines.append(f'    class {cls.__name__}["{cls.__name__} ({module}, {length} lines)"]')

    for cls in chain:
        declare(cls)
    for lower, upper in zip(chain[1:], chain, strict=False):
        lines.append(f"    {lower.__name__} <|-- {upper.__name__}")
    edges: list[str] = []
    todo, seen = list(chain), set(chain)
    while todo:
        cls = todo.pop(0)
        for attr, part in sorted(_parts(cls).items()):
            edges.append(f"    {cls.__name__} *-- {part.__name__} : {attr}")
            if part.__module__.startswith(home) and part not in seen:
                seen.add(part)
                todo.append(part)
                declare(part)
    lines.extend(edges)
    lines.append("```")
    return lines


#: Sphinx roles (``:class:`~a.b.C``` → ``C``) and literals (````x```` → ``x``) in a summary.
_ROLE: Final = re.compile(r":\w+:`~?(?:[\w.]*\.)?([^`]+)`")
_LITERAL: Final = re.compile(r"``([^`]+)``")
#: How long a summary may be before it is cut at a word.
_SUMMARY_WIDTH: Final = 72


def _summary(path: Path) -> str:
    """The first sentence of ``path``'s module docstring, in plain text, cut to
    :data:`_SUMMARY_WIDTH` characters at a word."""
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    text = " ".join(doc.partition("\n\n")[0].split())
    text = _LITERAL.sub(r"\1", _ROLE.sub(r"\1", text))
    text = re.split(r"(?<=\.)\s", text, maxsplit=1)[0].rstrip(".")
    if len(text) > _SUMMARY_WIDTH:
        text = text[:_SUMMARY_WIDTH].rsplit(" ", 1)[0].rstrip(",;:") + " …"
    return text


def tree_listing(package: str = "core", root: Path = PACKAGE) -> list[str]:
    """``package``'s folders and modules, each with its length and the first line of its
    docstring: the layout the folders themselves show."""
    top = root / package
    lines = ["```text"]

    def listing(folder: Path, depth: int) -> None:
        indent = "  " * depth
        modules = sorted(p for p in folder.glob("*.py") if p.name != "__init__.py")
        width = max((len(p.name) for p in modules), default=0)
        for path in modules:
            length = len(path.read_text(encoding="utf-8").splitlines())
            name = path.name.ljust(width)
            lines.append(f"{indent}{name}  {length:4} lines  {_summary(path)}")
        for sub in sorted(p for p in folder.iterdir() if (p / "__init__.py").is_file()):
            lines.append(f"{indent}{sub.name}/  {_summary(sub / '__init__.py')}")
            listing(sub, depth + 1)

    lines.append(f"{package}/  {_summary(top / '__init__.py')}")
    listing(top, 1)
    lines.append("```")
    return lines


def _self_call(func: ast.expr) -> tuple[str, str] | None:
    """``("part", "name")`` for ``self.part.name``, ``("self", "name")`` for ``self.name``."""
    if not isinstance(func, ast.Attribute):
        return None
    if _on_self(func):
        return "self", func.attr
    inner = func.value
    if isinstance(inner, ast.Attribute) and _on_self(inner):
        return inner.attr, func.attr
    return None


def method_calls(cls: type) -> dict[str, list[tuple[str, str]]]:
    """Public method of ``cls`` → the calls it makes on ``self.<part>`` or on ``self``, in
    the order they appear, once each; a call through a local alias (``check =
    self.guard.check``) counts as the call it names."""
    tree = ast.parse(inspect.getsource(cls))
    klass = tree.body[0]
    assert isinstance(klass, ast.ClassDef)
    out: dict[str, list[tuple[str, str]]] = {}
    for method in klass.body:
        if not isinstance(method, ast.FunctionDef) or method.name.startswith("_"):
            continue
        aliases: dict[str, tuple[str, str]] = {}
        calls: list[tuple[int, int, tuple[str, str]]] = []
        for node in ast.walk(method):
            if isinstance(node, ast.Assign) and len(node.targets) == 1:
                target, ref = node.targets[0], _self_call(node.value)
                if isinstance(target, ast.Name) and ref is not None:
                    aliases[target.id] = ref
        for node in ast.walk(method):
            if not isinstance(node, ast.Call):
                continue
            func = node.func
            ref = aliases.get(func.id) if isinstance(func, ast.Name) else _self_call(func)
            if ref is not None:
                # By where the call ends: an inner call (``self.endpoint.ready()`` in
                # ``self.send(self.endpoint.ready().packets)``) runs first.
                end = (node.end_lineno or node.lineno, node.end_col_offset or 0)
                calls.append((*end, ref))
        seen: list[tuple[str, str]] = []
        for _, _, ref in sorted(calls):
            if ref not in seen:
                seen.append(ref)
        out[method.name] = seen
    return out


def _annotation(node: ast.expr | None) -> str:
    return "" if node is None else ast.unparse(node)


def endpoint_ways(root: Path = PACKAGE) -> dict[str, tuple[list[str], list[str]]]:
    """``"module:Class"`` → (ways in, ways out) of every class of ``root`` (protocols left
    out) that takes packets with a ``receive_packet``: its public methods that take a
    packet (a ``Packet`` parameter, or bytes given to a ``receive…`` method) and those that
    return packets (a ``Ready`` or ``Outgoing``)."""
    found: dict[str, tuple[list[str], list[str]]] = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root).parts
        if parts[0] in LEFT_OUT:
            continue
        module = ".".join((*parts[:-1], path.stem)).removesuffix(".__init__")
        for klass in ast.parse(path.read_text(encoding="utf-8")).body:
            if not isinstance(klass, ast.ClassDef):
                continue
            if any("Protocol" in ast.unparse(base) for base in klass.bases):
                continue
            methods = [
                m
                for m in klass.body
                if isinstance(m, ast.FunctionDef) and not m.name.startswith("_")
            ]
            if "receive_packet" not in {m.name for m in methods}:
                continue
            ins: list[str] = []
            outs: list[str] = []
            for m in methods:
                taken = [_annotation(a.annotation) for a in m.args.args + m.args.kwonlyargs]
                if any("Packet" in t for t in taken) or (
                    m.name.startswith("receive") and any("bytes" in t for t in taken)
                ):
                    ins.append(m.name)
                returned = _annotation(m.returns)
                if "Ready" in returned or "Outgoing" in returned:
                    outs.append(m.name)
            found[f"{module}:{klass.name}"] = (ins, outs)
    return found


def ways_diagram(qualified: str = "actorswarm.security.pipeline:Pipeline") -> list[str]:
    module_name, _, name = qualified.partition(":")
    pipeline: type = getattr(importlib.import_module(module_name), name)
    kinds = {
        p: str(param.annotation) for p, param in inspect.signature(pipeline).parameters.items()
    }
    calls = method_calls(pipeline)
    lines = ["```mermaid", "flowchart LR"]
    lines.append(f'    subgraph {name}["{name} ({module_name.removeprefix("actorswarm.")})"]')
    for method in calls:
        params = list(inspect.signature(getattr(pipeline, method)).parameters.values())[1:2]
        taken = ", ".join(f"{p.name}: {p.annotation}" for p in params)
        lines.append(f'        {name}_{method}["{method}({taken})"]')
    lines.append("    end")
    parts = sorted({part for refs in calls.values() for part, _ in refs} - {"self"})
    for part in parts:
        lines.append(f'    {part}["{part}: {kinds.get(part, "?")}"]')
    for method, refs in calls.items():
        for part, called in refs:
            if part == "self":
                lines.append(f"    {name}_{method} --> {name}_{called}")
            else:
                lines.append(f'    {name}_{method} -- "{called}()" --> {part}')
    if "endpoint" in parts:
        for index, (where, (ins, outs)) in enumerate(sorted(endpoint_ways().items())):
            module, _, cls = where.partition(":")
            label = f"{cls} ({module})<br/>in: {', '.join(ins)}<br/>out: {', '.join(outs)}"
            lines.append(f'    endpoint{index}["{label}"] -. is an .-> endpoint')
    lines.append("```")
    return lines


def render() -> str:
    """The generated block, without its markers."""
    lines = [
        f"<!-- Generated from the source tree by `{COMMAND}`. -->",
        "",
        "The packages of `src/actorswarm/` and what each imports at run time (an arrow that",
        "a longer path implies is left out):",
        "",
        *packages_diagram(),
        "",
        "A platform's `Node`: its class chain, each class with its length, and the parts",
        "each class creates and keeps (the node's own parts, of `core/node/`, with theirs):",
        "",
        *node_diagram(),
        "",
        "The master's side of barriers, `BarrierMaster` (`core/barrier/`), and the task",
        "engine, `TaskEngine` (`engine/`), drawn the same way:",
        "",
        *node_diagram("actorswarm.core.barrier:BarrierMaster"),
        "",
        *node_diagram("actorswarm.engine.engine:TaskEngine"),
        "",
        "The collective core laid out by part (`src/actorswarm/core/`): the vocabulary every",
        "part shares at the top (packets, events, settings, the output collector), a folder",
        "per part below it:",
        "",
        *tree_listing(),
        "",
        "A packet's way in and out: what each method of the one packet pipeline calls on its",
        "parts, and every endpoint it serves (each class with a `receive_packet`) with its",
        "ways in (methods that take a packet) and out (methods that return packets):",
        "",
        *ways_diagram(),
    ]
    return "\n".join(lines) + "\n"


BLOCK: Final = GeneratedBlock("architecture pictures", DOC, BEGIN, END, COMMAND, render)


if __name__ == "__main__":
    sys.exit(BLOCK.main())
