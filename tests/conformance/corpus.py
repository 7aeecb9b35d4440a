"""POV-Ray's example suite as a test corpus: which scenes there are, which frame each one
shows, and which standard include files it reads.

The suite is Debian's `povray-examples` (/usr/share/doc/povray/examples); its scenes are
run where they are copied to, never in place (the folder is read-only and some scenes
write files).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

EXAMPLES = Path("/usr/share/doc/povray/examples")
POV_INCLUDE = Path("/usr/share/povray-3.7/include")

_FILE_NAME = re.compile(r'"([^"\n]+\.\w+)"')  # a quoted name with an extension


@dataclass(frozen=True)
class Frame:
    """The animation frame a scene is compared at (POV-Ray's first frame of its .ini)."""

    clock: float = 0.0
    number: int | None = None  # frame_number in POV-Ray; None: a still image
    first: int = 1
    last: int = 1
    initial_clock: float = 0.0
    final_clock: float = 1.0

    def povray_options(self) -> list[str]:
        """POV-Ray switches that render exactly this frame (and only it)."""
        if self.number is None:
            return [f"+K{self.clock:g}"]
        return [
            f"+KFI{self.first}",
            f"+KFF{self.last}",
            f"+KI{self.initial_clock:g}",
            f"+KF{self.final_clock:g}",
            f"+SF{self.number}",
            f"+EF{self.number}",
        ]


def scenes(root: Path = EXAMPLES) -> list[Path]:
    """Every .pov scene of the suite, in a stable order."""
    return sorted(root.rglob("*.pov"))


def _ini_settings(path: Path) -> dict[str, str]:
    """The main section of a POV-Ray INI file as lower-case key → value (`;` comments);
    `+KFI1`-style switches become their long names."""
    switches = {"kfi": "initial_frame", "kff": "final_frame", "ki": "initial_clock"}
    switches |= {"kf": "final_clock", "k": "clock"}
    out: dict[str, str] = {}
    for raw in path.read_text(encoding="utf-8", errors="replace").splitlines():
        line = raw.split(";", 1)[0].strip()
        if line.startswith("["):
            break
        for token in line.split() if line[:1] in "+-" else [line]:
            if token[:1] == "+":
                m = re.fullmatch(r"\+(kfi|kff|ki|kf|k)([-0-9.]+)", token, re.IGNORECASE)
                if m:
                    out[switches[m.group(1).lower()]] = m.group(2)
                continue
            key, sep, value = token.partition("=")
            if sep:
                out[key.strip().lower()] = value.strip().strip('"')
    return out


def ini_for(scene: Path) -> Path | None:
    """The .ini beside a scene that renders it (by Input_File_Name, else by name)."""
    for ini in sorted(scene.parent.glob("*.ini")):
        name = _ini_settings(ini).get("input_file_name", "")
        if name and Path(name).name.lower() == scene.name.lower():
            return ini
    same = scene.with_suffix(".ini")
    return same if same.exists() else None


def _number(text: str | None, default: float) -> float:
    try:
        return float(text) if text else default
    except ValueError:
        return default


def frame_for(scene: Path) -> Frame:
    """The frame to compare: the first frame of the scene's .ini animation, its `Clock`
    for a still, clock 0 without an .ini."""
    ini = ini_for(scene)
    if ini is None:
        return Frame()
    s = _ini_settings(ini)
    if "initial_frame" in s or "final_frame" in s:
        first = int(_number(s.get("initial_frame"), 1))
        last = int(_number(s.get("final_frame"), first))
        if last > first:
            initial = _number(s.get("initial_clock"), 0.0)
            final = _number(s.get("final_clock"), 1.0)
            return Frame(initial, first, first, last, initial, final)
    return Frame(_number(s.get("clock"), _number(s.get("initial_clock"), 0.0)))


def file_names(scene: Path) -> set[str]:
    """File names the scene quotes (includes, fonts, images), following the files in its
    own folder that it names, transitively."""
    seen: set[str] = set()
    pending = [scene]
    while pending:
        try:
            text = pending.pop().read_text(encoding="utf-8", errors="replace")
        except OSError:
            continue
        for name in _FILE_NAME.findall(text):
            if name in seen:
                continue
            seen.add(name)
            local = scene.parent / name
            if local.is_file():
                pending.append(local)
    return seen


def uses_standard_includes(scene: Path) -> bool:
    """True when the scene names a file of POV-Ray's include folder (an include file, a
    font, an image), so its result can differ between `-L` that folder and the stdlib."""
    return any(
        (POV_INCLUDE / n).is_file() and not (scene.parent / n).is_file() for n in file_names(scene)
    )


# A quick, representative slice of the suite for the default test run, from every family
# of the suite (objects, cameras, lights, patterns, finishes, interiors, language,
# animation): scenes both renderers finish in under two seconds at 160x120, chosen on
# the full run: those that matched POV-Ray, and the quickest others per family (scenes
# that do not evaluate yet, or render unlike POV-Ray) so that progress shows too.
FAST_SUBSET: tuple[str, ...] = (
    "advanced/bwstripe.pov",
    "advanced/cliche/sign.pov",
    "advanced/crater/crater.pov",
    "advanced/crater/crater_dat.pov",
    "advanced/diffract.pov",
    "animations/clockd/clockd.pov",
    "camera/mesh_camera/baking_repair_seams.pov",
    "camera/orthographic.pov",
    "camera/perspective.pov",
    "camera/shear.pov",
    "incdemo/debug.pov",
    "incdemo/finish.pov",
    "incdemo/i_internal.pov",
    "incdemo/metals/chromes.pov",
    "incdemo/strings.pov",
    "incdemo/sundial.pov",
    "incdemo/woods/bubinga_37.pov",
    "interior/atten2.pov",
    "interior/fog_f.pov",
    "interior/fog_ft.pov",
    "interior/fog_std.pov",
    "interior/media/media1.pov",
    "language/bounding.pov",
    "language/fileio/fileio.pov",
    "language/macros/local.pov",
    "language/macros/macro1.pov",
    "language/macros/macro2.pov",
    "language/macros/macro3.pov",
    "lights/fillite.pov",
    "lights/parallel_lights.pov",
    "objectmods/double_illuminate.pov",
    "objects/quartic/folium.pov",
    "objects/superel1.pov",
    "objects/superel3.pov",
    "portfolio/t_metals.pov",
    "portfolio/t_stars.pov",
    "textures/patterns/gradient.pov",
    "textures/patterns/marble.pov",
    "textures/pigments/interp.pov",
    "textures/pigments/mapper.pov",
    "textures/pigments/mappr2.pov",
    "textures/pigments/matmap.pov",
)
