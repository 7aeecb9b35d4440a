"""strala's diagnostics as SARIF 2.1.0, the static-analysis log that editors and code hosts
read: every code as a rule, each diagnostic a result, macro call sites as related places."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from lang.diagnostics import DEFAULT_HINTS, TITLES, Diagnostic, Severity, Span


def rules() -> list[dict]:
    """Every code strala reports, as SARIF rules: its title, default hint and level."""
    levels = {"E": "error", "W": "warning", "N": "note"}
    return [
        {
            "id": code,
            "shortDescription": {"text": title},
            **({"help": {"text": DEFAULT_HINTS[code]}} if code in DEFAULT_HINTS else {}),
            "defaultConfiguration": {"level": levels[code[0]]},
        }
        for code, title in sorted(TITLES.items())
    ]


def _place(span: Span) -> dict:
    return {
        "artifactLocation": {"uri": Path(span.file).as_posix()},
        "region": {
            "startLine": span.line,
            "startColumn": span.col,
            "endLine": span.end_line,
            "endColumn": span.end_col,
        },
    }


def report(diags: Sequence[Diagnostic], version: str) -> dict:
    """The diagnostics as a SARIF 2.1.0 log (`strala check --format sarif`)."""
    levels = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.NOTE: "note"}
    table = rules()
    index = {rule["id"]: i for i, rule in enumerate(table)}
    results = []
    for d in diags:
        result = {
            "ruleId": d.code,
            **({"ruleIndex": index[d.code]} if d.code in index else {}),
            "level": levels[d.severity],
            "message": {"text": d.message + (f" (hint: {d.hint})" if d.hint else "")},
            "locations": [{"physicalLocation": _place(d.span)}],
        }
        if d.called_from:  # the macro calls a body's mistake was reached through
            result["relatedLocations"] = [
                {
                    "id": i,
                    "physicalLocation": _place(at),
                    "message": {"text": f"in macro `{name}` called here"},
                }
                for i, (name, at) in enumerate(d.called_from, start=1)
            ]
        results.append(result)
    return {
        "version": "2.1.0",
        "$schema": "https://json.schemastore.org/sarif-2.1.0.json",
        "runs": [
            {
                "tool": {"driver": {"name": "strala", "version": version, "rules": table}},
                "results": results,
            }
        ],
    }
