"""POV-Ray's options on strala's command line: switches (`+W512 -A +KFI1`), INI files and
INI settings (`Width=512`, `Declare=Rad=1.2`), rewritten as strala's own options.

Both forms become INI settings first (a switch is POV-Ray's short name for one, as its own
option table pairs them), so one table says what strala does with each; the settings are
then turned into strala options once all are read (POV-Ray's last value wins, and a
threshold alone does not turn anti-aliasing on). An option strala does not act on is
dropped with one "ignoring …" warning; only the ones that change nothing in a file render
(console streams, video modes) are dropped silently. `+D`/`Display` opens strala's display
window and `+P`/`Pause_When_Done` keeps it open at the end.

Standard library only: `strala check` imports this and must start fast.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path

from lang.ini import ini_tokens


class OptionError(Exception):
    """A POV-Ray option that cannot be read (a missing value, an unreadable INI file)."""


# Switch → (the INI key its parameter sets, the INI key a bare +/- turns on or off), in
# POV-Ray's matching order: a longer name before a shorter one it starts with.
SWITCHES: tuple[tuple[str, str | None, str | None], ...] = (
    ("AC", "antialias_confidence", None),  # POV-Ray 3.8's
    ("AG", "antialias_gamma", None),
    ("AM", "sampling_method", None),
    ("A", "antialias_threshold", "antialias"),
    ("BM", "bounding_method", None),
    ("BS", "render_block_size", None),
    ("B", None, "bounding"),
    ("C", None, "continue_trace"),
    ("D", "video_mode", "display"),  # +D0 …: a video mode and palette, POV-Ray's DOS ones
    ("EC", "end_column", None),
    ("EF", "subset_end_frame", None),
    ("EP", "preview_end_size", None),
    ("ER", "end_row", None),
    ("F", "output_file_type", "output_to_file"),
    ("GA", "all_file", "all_console"),
    ("GD", "debug_file", "debug_console"),
    ("GF", "fatal_file", "fatal_console"),
    ("GI", "create_ini", None),
    ("GP", None, "append_file"),
    ("GR", "render_file", "render_console"),
    ("GS", "statistic_file", "statistic_console"),
    ("GW", "warning_file", "warning_console"),
    ("HI", "include_header", None),
    ("HR", None, "high_reproducibility"),
    ("H", "height", None),
    ("I", "input_file_name", None),
    ("J", "jitter_amount", "jitter"),
    ("KC", None, "cyclic_animation"),
    ("KI", "initial_clock", None),
    ("KFF", "final_frame", None),
    ("KFI", "initial_frame", None),
    ("KF", "final_clock", None),
    ("KLA", None, "clockless_animation"),
    ("K", "clock", None),
    ("L", "library_path", None),
    ("MB", "bounding_threshold", "bounding"),
    ("MI", "max_image_buffer_memory", None),
    ("MV", "version", None),
    ("O", "output_file_name", None),
    ("P", None, "pause_when_done"),
    ("Q", "quality", None),
    ("RFI", None, "radiosity_from_file"),
    ("RFO", None, "radiosity_to_file"),
    ("RF", "radiosity_file_name", None),
    ("RS", "render_block_step", None),
    ("RP", "render_pattern", None),
    ("RTR", None, "real_time_raytracing"),
    ("RVP", None, "radiosity_vain_pretrace"),
    ("R", "antialias_depth", None),
    ("SC", "start_column", None),
    ("SF", "subset_start_frame", None),
    ("SP", "preview_start_size", None),
    ("SR", "start_row", None),
    ("STP", "frame_step", None),
    ("SU", None, "split_unions"),
    ("TH", "dither_method", "dither"),
    ("UA", None, "output_alpha"),
    ("UD", None, "draw_vistas"),
    ("UF", None, "field_render"),
    ("UL", None, "light_buffer"),
    ("UO", None, "odd_field"),
    ("UR", None, "remove_bounds"),
    ("UV", None, "vista_buffer"),
    ("V", None, "verbose"),
    ("WL", "warning_level", None),
    ("WT", "work_threads", None),
    ("W", "width", None),
    ("X", "test_abort_count", "test_abort"),
)

# INI keys strala acts on (see _strala_options); a key may be given many times in these
HANDLED = {
    "input_file_name", "output_file_name", "width", "height", "antialias",
    "antialias_threshold", "antialias_depth", "library_path", "clock", "work_threads",
    "initial_frame", "final_frame", "subset_start_frame", "subset_end_frame",
    "start_column", "end_column", "start_row", "end_row", "output_file_type", "declare",
    "sampling_method", "jitter", "jitter_amount", "antialias_gamma", "cyclic_animation",
    "initial_clock", "final_clock", "frame_step", "display", "pause_when_done",
}  # fmt: skip
REPEATED = {"library_path", "declare"}

# What changes nothing in an image file: console streams and their files, the abort test,
# statistics, video modes. Dropped without a word.
QUIET = {
    "verbose", "test_abort", "test_abort_count",
    "all_console", "all_file", "debug_console", "debug_file", "fatal_console", "fatal_file",
    "render_console", "render_file", "statistic_console", "statistic_file",
    "warning_console", "warning_file", "append_file", "warning_level", "display_gamma",
    "video_mode", "palette", "draw_vistas", "preview_start_size", "preview_end_size",
    "create_ini", "buffer_output", "buffer_size", "histogram_name", "histogram_type",
    "histogram_grid_size", "create_histogram", "output_to_file",
}  # fmt: skip

# Every other INI key POV-Ray 3.7 reads: known, not done by strala, warned about by name.
KNOWN = {s[k] for s in SWITCHES for k in (1, 2) if s[k]} | HANDLED | QUIET
KNOWN |= {
    "bits_per_color", "bits_per_colour", "bounding_threshold", "bsp_baseaccesscost",
    "bsp_childaccesscost", "bsp_isectcost", "bsp_maxdepth", "bsp_misschance", "compression",
    "dither_method", "fatal_error_command", "fatal_error_return", "file_gamma",
    "include_ini", "post_frame_command", "post_frame_return", "post_scene_command",
    "post_scene_return", "pre_frame_command", "pre_frame_return", "pre_scene_command",
    "pre_scene_return", "user_abort_command", "user_abort_return", "grayscale_output",
}  # fmt: skip

# POV-Ray 3.8's keys: not 3.7's, and what strala does instead
NEWER = {
    "antialias_confidence": "POV-Ray 3.8's, for anti-aliasing method 3; strala renders "
    "method 3 as method 2, which has no confidence",
}

_FILE_TYPES = {"N": ".png", "E": ".exr", "J": ".jpg"}
_REGION = {
    "start_column": "--start-col",
    "end_column": "--end-col",
    "start_row": "--start-row",
    "end_row": "--end-row",
}
_ANIMATION = {
    "initial_clock": "--initial-clock",
    "final_clock": "--final-clock",
    "subset_start_frame": "--subset-start",
    "subset_end_frame": "--subset-end",
    "frame_step": "--frame-step",
}
_TRUE = {"on", "true", "yes", "1"}
_SETTING = re.compile(r"[A-Za-z][A-Za-z0-9_]*=")  # `Width=512` on the command line

# Options that take a separate value: the token after them is never translated.
VALUE_OPTIONS = {"-o", "-W", "-H", "--aa-depth", "-L", "--library", "--threads", "--bits"}
VALUE_OPTIONS |= {"--clock", "--format", "--output", "--width", "--height", "--frames"}
VALUE_OPTIONS |= {"--frame", "--cluster", "--tiles", "--declare", "--aa-method"}
VALUE_OPTIONS |= {"--jitter", "--aa-gamma", "-r", "--recursive", "--frame-step"}
VALUE_OPTIONS |= {"--initial-clock", "--final-clock", "--subset-start", "--subset-end"}
VALUE_OPTIONS |= {"--indent", "--output-type", "--radiosity-cache", "--reference"}
_OWN_SHORT = {"-o", "-W", "-H", "-L", "-q", "-h", "-r"}  # strala's own short options


def switch_settings(tok: str) -> list[tuple[str, str]] | None:
    """A POV-Ray switch (`+W512`, `-A`, `+A0.3`) → the INI settings it stands for, or None
    when POV-Ray has no such switch."""
    sign, body = tok[0], tok[1:]
    upper = body.upper()
    for name, value_key, flag_key in SWITCHES:
        if not upper.startswith(name):
            continue
        rest = body[len(name) :]
        if rest and value_key is None:
            continue  # `+GA` is not `+G` with "A"; `+KC…` no longer `+K`
        if name == "A" and rest and not _is_number(rest):
            continue
        out: list[tuple[str, str]] = []
        if flag_key is not None:
            out.append((flag_key, "on" if sign == "+" else "off"))
        if rest and value_key is not None:
            out.append((value_key, rest))
        elif flag_key is None:
            out.append((value_key or name, ""))  # a switch whose value is missing
        return out
    return None


def translate_povray_args(argv: Sequence[str], warn: list[str]) -> list[str]:
    """Rewrite POV-Ray style switches, INI files and INI settings into strala options;
    anything strala does not act on is dropped with a warning (in `warn`, each once)."""
    out: list[str] = []
    settings: dict[str, list[str]] = {}  # INI key → its values, in the order given
    origin: dict[str, str] = {}  # INI key → how the user wrote it, for warnings

    def note(message: str) -> None:
        if message not in warn:
            warn.append(message)

    warned: set[str] = set()  # one warning a key, however often it is given

    def setting(key: str, value: str, written: str) -> None:
        key = key.lower()
        if key in QUIET or (key in warned and key not in HANDLED):
            return
        if key not in HANDLED:
            warned.add(key)
        if key in NEWER:
            note(f"ignoring {written}: {NEWER[key]}")
            return
        if key not in KNOWN:
            note(f"ignoring {written}: not a POV-Ray 3.7 option")
            return
        if key not in HANDLED:
            note(f"ignoring POV-Ray option {written}")
            return
        if key in REPEATED:
            settings.setdefault(key, []).append(value)
        else:
            settings.pop(key, None)  # the last one given wins, in its place
            settings[key] = [value]
        origin[key] = written

    after_value_option = False
    pending = list(argv)
    while pending:
        tok = pending.pop(0)
        if after_value_option:
            out.append(tok)
            after_value_option = False
        elif tok in VALUE_OPTIONS:
            out.append(tok)
            after_value_option = True
        elif tok.lower().endswith(".ini") and not tok.startswith(("+", "-")):
            try:
                pending[:0] = ini_tokens(Path(tok))
            except OSError as exc:
                raise OptionError(f"cannot read {tok}: {exc.strerror}") from None
        elif _SETTING.match(tok):
            key, _, value = tok.partition("=")
            setting(key, value.strip(), tok)
        elif len(tok) < 2 or tok[0] not in "+-" or tok.startswith("--"):
            out.append(tok)
        elif _own_short(tok):
            out.append(tok)  # strala's own short option (-W512, -q…): argparse judges it
        else:
            found = switch_settings(tok)
            if found is None:
                note(f"ignoring {tok}: not a POV-Ray 3.7 option")
                continue
            for key, value in found:
                if not value and key in ("input_file_name", "output_file_name", "library_path"):
                    if not pending:
                        raise OptionError(f"{tok} needs a value")
                    value = pending.pop(0)  # POV-Ray's `+O out.png`
                setting(key, value, tok)
    return out + _strala_options(settings, origin, note)


def _strala_options(
    settings: dict[str, list[str]], origin: dict[str, str], note: Callable[[str], None]
) -> list[str]:
    """strala's options for the INI settings read (in the order they were first given)."""
    out: list[str] = []
    aa = settings.get("antialias")
    for key, values in settings.items():
        value = _unquote(values[-1])
        if key == "input_file_name":
            out.append(value)
        elif key == "output_file_name":
            out += ["-o", value]
        elif key in ("width", "height"):
            out += ["-" + key[0].upper(), value]
        elif key == "antialias":
            on = value.lower() in _TRUE
            threshold = settings.get("antialias_threshold")
            out += (["--aa", _unquote(threshold[-1])] if threshold else ["--aa"]) if on else []
            out += [] if on else ["--no-aa"]
        elif key == "antialias_threshold" and aa is None:
            note(f"ignoring POV-Ray option {origin[key]}: anti-aliasing is not turned on")
        elif key == "antialias_depth":
            out += ["--aa-depth", value]
        elif key == "sampling_method":
            out += ["--aa-method", value]
        elif key == "antialias_gamma":
            out += ["--aa-gamma", value]
        elif key == "jitter" and value.lower() not in _TRUE:
            out += ["--jitter", "0"]
        elif key == "jitter_amount" and settings.get("jitter", ["on"])[-1].lower() in _TRUE:
            out += ["--jitter", value]
        elif key == "library_path":
            for v in values:
                out += ["-L", _unquote(v)]
        elif key == "declare":
            for v in values:
                out += ["--declare", v]
        elif key == "clock":
            out += ["--clock", value]
        elif key in ("display", "pause_when_done"):
            flag = "--display" if key == "display" else "--pause"
            out.append(flag if value.lower() in _TRUE else flag.replace("--", "--no-"))
        elif key == "work_threads":
            out += ["--threads", value]
        elif key in _REGION:
            out += [_REGION[key], value]
        elif key == "output_file_type":
            kind = _FILE_TYPES.get(value[:1].upper())
            if kind is None:
                note(f"ignoring POV-Ray option {origin[key]} (strala writes PNG, EXR or JPEG)")
                continue
            out += ["--output-type", kind]
            if value[1:].isdigit():
                out += ["--bits", value[1:]]
    out += _frame_options(settings)
    return out


def _frame_options(settings: dict[str, list[str]]) -> list[str]:
    """--frames from Initial_Frame/Final_Frame, and the other animation settings."""
    out: list[str] = []
    first_last = [settings.get(k) for k in ("initial_frame", "final_frame")]
    if any(first_last):
        first = first_last[0][-1] if first_last[0] else "1"
        last = first_last[1][-1] if first_last[1] else first
        out += ["--frames", f"{first}..{last}"]
    for key, option in _ANIMATION.items():
        if key in settings:
            out += [option, _unquote(settings[key][-1])]
    if settings.get("cyclic_animation", ["off"])[-1].lower() in _TRUE:
        out.append("--cyclic")
    return out


def _own_short(tok: str) -> bool:
    """strala's -W512, -o out.png, -q…, which POV-Ray's -WT2, -HR, -Q9 only start like."""
    head, rest = tok[:2], tok[2:]
    if head in ("-W", "-H"):
        return not rest or rest.isdigit()
    if head in ("-q", "-h", "-r"):
        return not rest
    return head in _OWN_SHORT


def _unquote(text: str) -> str:
    text = text.strip()
    if len(text) >= 2 and text[0] == text[-1] == '"':
        return text[1:-1]
    return text


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def parse_declare(text: str) -> tuple[str, float]:
    """`Name=Value` → (name, value), as POV-Ray 3.7 reads a Declare option: the value is a
    float, read as C's atof does (the longest number it starts with; 0 when none)."""
    name, sep, value = text.partition("=")
    name = name.strip()
    if not sep or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise ValueError(f"expected Name=Value, got {text!r}")
    number = re.match(r"\s*[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", value)
    return name, float(number.group(0)) if number else 0.0
