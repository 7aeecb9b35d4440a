"""POV-Ray INI files: the one reader (the command line turns an INI file into POV-Ray
options with it; lang.paths takes the `Library_Path` entries of the INI file POV-Ray reads
by default from it)."""

from __future__ import annotations

from pathlib import Path


def ini_tokens(path: Path) -> list[str]:
    """POV-Ray INI file → command-line tokens (the main section only; `;` comments): a
    switch line gives its switches, a `Key=Value` line the token `Key=Value` (the form
    POV-Ray's command line takes too). OSError when the file cannot be read."""
    tokens: list[str] = []
    text = path.read_text(encoding="utf-8", errors="replace")
    for raw in text.splitlines():
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        if line.startswith("["):
            break  # named sections are for POV-Ray's +I<ini>[section]; strala reads the main one
        if line[0] in "+-":
            tokens.extend(line.split())
            continue
        key, sep, value = line.partition("=")
        if sep and key.strip():
            tokens.append(f"{key.strip()}={value.strip()}")
    return tokens


def library_paths_of(path: Path) -> list[str]:
    """The folders an INI file adds to the library path (`Library_Path=` and `+L`), in order;
    none when it cannot be read."""
    try:
        tokens = ini_tokens(path)
    except OSError:
        return []
    found = []
    for t in tokens:
        key, sep, value = t.partition("=")
        if sep and key.lower() == "library_path":
            found.append(value.strip('"'))
        elif t[:2] in ("+L", "+l") and len(t) > 2:
            found.append(t[2:])
    return found
