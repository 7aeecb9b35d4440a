"""One diagnostic type for every consumer: the CLI, `check`, the language server and tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum


@dataclass(frozen=True, slots=True)
class Span:
    """A source range; lines and columns are 1-based, the end is exclusive."""

    file: str
    line: int
    col: int
    end_line: int
    end_col: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.col}"

    def to_json(self) -> dict:
        return {
            "file": self.file,
            "line": self.line,
            "col": self.col,
            "end_line": self.end_line,
            "end_col": self.end_col,
        }


UNKNOWN_SPAN = Span("<unknown>", 1, 1, 1, 1)


class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True, slots=True)
class Diagnostic:
    severity: Severity
    code: str
    message: str
    span: Span
    hint: str | None = None

    def format(self, source_lines: list[str] | None = None) -> str:
        """gcc-style text, with the source line and a caret when the source is at hand."""
        out = f"{self.span}: {self.severity.value}: {self.message} [{self.code}]"
        if source_lines is not None and 1 <= self.span.line <= len(source_lines):
            text = source_lines[self.span.line - 1].rstrip("\n").expandtabs(1)
            width = 1
            if self.span.end_line == self.span.line and self.span.end_col > self.span.col:
                width = self.span.end_col - self.span.col
            out += f"\n {self.span.line:>4} | {text}\n      | {' ' * (self.span.col - 1)}^"
            out += "~" * (width - 1)
        if self.hint:
            out += f"\n      = hint: {self.hint}"
        return out

    def to_json(self) -> dict:
        return {
            "severity": self.severity.value,
            "code": self.code,
            "message": self.message,
            "span": self.span.to_json(),
            "hint": self.hint,
        }


@dataclass
class DiagnosticSink:
    """Collects diagnostics; evaluation goes on after an error where it safely can."""

    items: list[Diagnostic] = field(default_factory=list)

    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.ERROR, code, message, span, hint))

    def warning(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.WARNING, code, message, span, hint))

    def note(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.items.append(Diagnostic(Severity.NOTE, code, message, span, hint))

    @property
    def has_errors(self) -> bool:
        return any(d.severity is Severity.ERROR for d in self.items)


class SceneError(Exception):
    """Raised to abandon evaluation of one construct; carries its diagnostic."""

    def __init__(self, diagnostic: Diagnostic):
        super().__init__(diagnostic.message)
        self.diagnostic = diagnostic
