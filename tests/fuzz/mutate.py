"""Mutations of scene text for the fuzzing job (tests/fuzz/run.py) and its short version
in the default run (tests/test_fuzz.py): tokens deleted, duplicated or swapped, random
bytes, pieces that change how the rest reads (half a construct, an open string or comment,
a loop that cannot end), numbers at the edges of what floats hold, deep nesting, the text
cut short. Seeds are POV-Ray's example scenes (read where POV-Ray installed them, never
copied here) and this repository's examples."""

from __future__ import annotations

import random
from collections.abc import Sequence
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent.parent
POVRAY_EXAMPLES = Path("/usr/share/doc/povray/examples")

KINDS = ("delete", "duplicate", "swap", "bytes", "insert", "nest", "cut", "number")

# Halves of constructs, text that changes how the rest reads, runaway work
BREAKERS = (
    '"unterminated',
    "/* never closed",
    "// a comment\n",
    "{",
    "}",
    "(",
    ")",
    "<",
    ">",
    "[",
    "]",
    ",",
    "#if (1)",
    "#else",
    "#end",
    "#break",
    "#macro M(",
    "#declare",
    "#local X =",
    "#while (1)",
    "#for (I, 0, 1e9)",
    "#for (I, 0, 999999) #for (J, 0, 999999)",
    '#include "',
    '#include "/etc/passwd"',
    "#switch (1)",
    "#case (",
    "#version 1e9;",
    '#fopen F "nodir/x.txt" write',
    "function {",
    "spline {",
    "array[9999999]",
    "str(1, 1e9, 0)",
    "camera { angle 0 }",
    "radiosity {}",
    "fog { distance -1 rgb 1 }",
    "translate <1, 0, 1e300>",
    "scale 0",
    "scale 1e-300",
    "rotate <1e300, 0, 0>",
    "matrix <0,0,0, 0,0,0, 0,0,0, 0,0,0>",
    "\x00",
    "\t\r",
)
# Numbers at the edges of what floats (and the integers made from them) hold
NUMBERS = ("1e308 * 10", "-1e400", "1e-400", "1e300", "-1e300", "0", "-0", "1e-320",
           "2147483648", "-2147483649", "9" * 400, "0/0", "1/0", "sqrt(-1)")  # fmt: skip
OPENERS = ("(", "<", "union {", "#if (1)", "{", "pigment {", "-", "#macro M(", "[", "!")


def seeds(povray: bool = True) -> dict[str, str]:
    """name -> text of every seed scene: this repository's examples, and POV-Ray's
    where it is installed."""
    out = {p.name: p.read_text() for p in sorted((ROOT / "examples").glob("*.scene"))}
    if povray and POVRAY_EXAMPLES.is_dir():
        for p in sorted(POVRAY_EXAMPLES.rglob("*.pov")):
            try:
                out[str(p.relative_to(POVRAY_EXAMPLES))] = p.read_text(errors="replace")
            except OSError:
                continue
    return out


def mutate(text: str, mutations: Sequence[tuple[str, int]]) -> str:
    """`text` with each (kind, seed) mutation applied in turn, on space-separated tokens."""
    tokens = text.split(" ")
    for kind, seed in mutations:
        rng = random.Random(seed)
        i = rng.randrange(len(tokens)) if tokens else 0
        if kind == "delete" and tokens:
            del tokens[i : i + rng.randrange(1, 4)]
        elif kind == "duplicate" and tokens:
            tokens[i:i] = tokens[i : i + rng.randrange(1, 4)]
        elif kind == "swap" and tokens:
            j = rng.randrange(len(tokens))
            tokens[i], tokens[j] = tokens[j], tokens[i]
        elif kind == "bytes":
            n = rng.randrange(1, 12)
            tokens.insert(i, "".join(chr(rng.randrange(0, 0x250)) for _ in range(n)))
        elif kind == "insert":
            tokens.insert(i, rng.choice(BREAKERS))
        elif kind == "number":
            numeric = [k for k, t in enumerate(tokens) if t[:1].isdigit()]
            k = rng.choice(numeric) if numeric else i
            tokens[k : k + 1] = [rng.choice(NUMBERS)]
        elif kind == "nest":
            tokens.insert(i, rng.choice(OPENERS) * rng.randrange(1, 300))
        else:
            tokens = tokens[:i]
    return " ".join(tokens)


def random_mutations(rng: random.Random, most: int = 4) -> list[tuple[str, int]]:
    return [(rng.choice(KINDS), rng.randrange(2**31)) for _ in range(rng.randrange(1, most + 1))]
