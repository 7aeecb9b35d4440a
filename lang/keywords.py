"""POV-Ray 3.7's reserved words, sorted into the classes the grammar needs.

The grammar only distinguishes words that change the *shape* of the text: value keywords
(constants, built-in functions, colour constructors and components), listed here, and the
rest, which lang/schema.py lists (with the block each belongs to) and which are one KEYWORD
terminal. The directives are the grammar's own terminals.
"""

from __future__ import annotations

from lang import schema

# Built-in value keywords: used as operands in expressions.
CONSTANTS = frozenset(
    """
    x y z t u v pi tau clock clock_delta clock_on final_clock final_frame frame_number
    initial_clock initial_frame image_width image_height true false on off yes no version
    now input_file_name
    """.split()
)

# Built-in functions: always called as `name(args)` (`pwr(X, Y)` only in a julia_fractal).
FUNCTIONS = frozenset(
    """
    abs acos acosh asc asin asinh atan atan2 atanh bitwise_and bitwise_or bitwise_xor ceil
    chr concat cos cosh datetime defined degrees dimension_size dimensions div exp
    file_exists floor inside int ln log max max_extent min min_extent mod pow prod pwr radians
    rand seed select sin sinh sqr sqrt str strcmp strlen strlwr strupr substr sum tan tanh
    trace val vaxis_rotate vcross vdot vlength vnormalize vrotate vstr vturbulence
    """.split()
)

COLOR_TYPES = frozenset("rgb rgbf rgbt rgbft srgb srgbf srgbt srgbft".split())
COLOR_WORDS = frozenset(("color", "colour"))
# Colour components: the old `color red 1 green .5` form and `.red` member access.
COMPONENTS = frozenset("red green blue filter transmit gray grey".split())

# Directive words (written with a leading '#').
DIRECTIVES = frozenset(
    """
    include declare local undef if elseif else end ifdef ifndef switch case range break
    while for macro version debug warning error default fopen fclose read write render
    statistics
    """.split()
)

# Every other reserved word: block heads and item keywords, as the schema lists them (the one
# list of the language's words). Words that are items but also directive names (read/write
# as #fopen modes) stay items.
ITEM_WORDS = schema.RESERVED_WORDS - CONSTANTS - FUNCTIONS - COLOR_TYPES - COLOR_WORDS - COMPONENTS
# strala's own item words that read as plain identifiers (users may have variables with these
# names): the evaluator takes them as keywords only inside the blocks whose schema lists them.
SOFT_WORDS = schema.SOFT_WORDS

ALL_WORDS = CONSTANTS | FUNCTIONS | COLOR_TYPES | COLOR_WORDS | COMPONENTS | ITEM_WORDS
