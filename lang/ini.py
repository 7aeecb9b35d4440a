"""POV-Ray INI files: the one reader (the command line turns an INI file into POV-Ray
switches with it; lang.paths takes the `Library_Path` entries of the INI file POV-Ray reads
by default from it)."""

from __future__ import annotations

from pathlib import Path

# INI keys → the POV-Ray switch each one stands for (the value follows the switch)
KEYS = {
    "input_file_name": "+I",
    "output_file_name": "+O",
    "width": "+W",
    "height": "+H",
    "antialias_threshold": "+A",
    "antialias_depth": "+R",
    "library_path": "+L",
    "clock": "+K",
    "work_threads": "+WT",
    "initial_frame": "+KFI",
    "final_frame": "+KFF",
    "start_column": "+SC",
    "end_column": "+EC",
    "start_row": "+SR",
    "end_row": "+ER",
}


def ini_tokens(path: Path) -> list[str]:
    """POV-Ray INI file → command-line tokens (the main section only; `;` comments).
    OSError when the file cannot be read."""
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
        key, value = key.strip().lower(), value.strip().strip('"')
        if not sep:
            continue
        if key == "antialias":
            tokens.append("+A" if value.lower() in ("on", "true", "yes", "1") else "-A")
        elif key in KEYS:
            tokens.append(KEYS[key] + value)
    return tokens


def library_paths_of(path: Path) -> list[str]:
    """The folders an INI file adds to the library path (`Library_Path=` and `+L`), in order;
    none when it cannot be read."""
    try:
        tokens = ini_tokens(path)
    except OSError:
        return []
    return [t[2:] for t in tokens if t[:2] in ("+L", "+l") and len(t) > 2]
