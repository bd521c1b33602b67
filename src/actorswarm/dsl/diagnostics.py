"""What the checker says about a script: positioned errors and warnings.

A :class:`Diagnostic` prints like a compiler message, ``file:line:col: message`` (warnings as
``file:line:col: warning: message``), so editors and terminals can jump to it. Messages are
written as instructions: what is wrong, and what to write instead. :class:`Report` is the
collector the checking stages share; :class:`ScriptError` is how :func:`~actorswarm.dsl.load`
refuses a script.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Literal

from actorswarm.dsl.model import Position

Severity = Literal["error", "warning"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Diagnostic:
    """One finding: ``severity`` at ``line``:``col`` of ``path``."""

    path: str
    line: int
    col: int
    message: str
    severity: Severity = "error"

    def __str__(self) -> str:
        tag = "warning: " if self.severity == "warning" else ""
        return f"{self.path}:{self.line}:{self.col}: {tag}{self.message}"


class ScriptError(ValueError):
    """A task script was refused. ``diagnostics`` holds every error (and warning) found,
    in script order; ``str()`` is their printed lines."""

    def __init__(self, diagnostics: Iterable[Diagnostic]) -> None:
        self.diagnostics = tuple(diagnostics)
        super().__init__("\n".join(str(d) for d in self.diagnostics))

    @property
    def errors(self) -> tuple[Diagnostic, ...]:
        """The diagnostics that made the script invalid."""
        return tuple(d for d in self.diagnostics if d.severity == "error")


@dataclass(slots=True)
class Report:
    """Collects diagnostics for one script while the checking stages run."""

    path: str
    diagnostics: list[Diagnostic] = field(default_factory=list)

    def error(self, pos: Position, message: str) -> None:
        """Record an error at ``pos``: the script will be refused."""
        self.diagnostics.append(
            Diagnostic(
                path=self.path, line=pos.line, col=pos.col, message=message, severity="error"
            )
        )

    def warning(self, pos: Position, message: str) -> None:
        """Record a warning at ``pos``: worth a look, but the script is accepted."""
        self.diagnostics.append(
            Diagnostic(
                path=self.path, line=pos.line, col=pos.col, message=message, severity="warning"
            )
        )

    @property
    def has_errors(self) -> bool:
        """Whether any error was recorded."""
        return any(d.severity == "error" for d in self.diagnostics)

    def sorted(self) -> tuple[Diagnostic, ...]:
        """Everything recorded, in script order (stable for findings at one place)."""
        return tuple(sorted(self.diagnostics, key=lambda d: (d.line, d.col)))
