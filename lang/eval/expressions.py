"""Expressions: numbers, strings, identifiers, vectors, operators, member and index access,
calls of built-in functions, macros, user functions and splines, colour and array literals,
trace()/inside() and min_extent()/max_extent(). One function per syntax node kind,
dispatched by EXPRESSIONS."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from lang import (
    builtins,
    schema,
    syntax,
)
from lang.builtins import EvalError, as_color, as_float, as_vec
from lang.diagnostics import Span
from lang.eval import generated, trace_walk
from lang.eval.context import BuildContext
from lang.eval.splines import evaluate_spline
from lang.extents import bounding_box
from lang.values import (
    ArrayValue,
    ColorValue,
    FunctionValue,
    MacroValue,
    ObjectValue,
    SplineValue,
    UnsupportedValue,
    Vec,
    describe,
)

MAX_ARRAY_ELEMENTS = 10_000_000  # a larger array is a mistake (and would exhaust memory)
ARRAY_SLOT_BYTES = 8  # an element's slot (a pointer) before anything is stored in it


def _e_number(it: BuildContext, node: syntax.Number) -> float:
    return node.value


def _e_string(it: BuildContext, node: syntax.String) -> str:
    v = node.value
    if v.isascii() or it.version < 3.5 or it.settings.get("charset", "ascii") != "ascii":
        return v
    # POV-Ray's String_To_UCS2 under `charset ascii` (the default): each byte of a
    # non-ASCII character (its UTF-8 bytes, as the file holds them) becomes a space
    it.sink.warning(
        "W0309",
        "Non-ASCII character has been replaced by space character.",
        node.span,
        "POV-Ray does the same under `charset ascii`, the default; for the character, give"
        " `global_settings { charset utf8 }`",
    )
    return "".join(c if c.isascii() else " " * len(c.encode("utf-8", "replace")) for c in v)


def _e_ident(it: BuildContext, node: syntax.Ident) -> Any:
    found, v = it.lookup(node.name)
    if not found:
        raise it.unknown_ident(node.name, node.span)
    if it.deprecated and node.name in it.deprecated:
        _warn_deprecated(it, node)
    if isinstance(v, MacroValue):
        if not v.params:
            return it.single(
                it.call_macro(syntax.Call(node.span, node.name, [], False)),
                node.span,
                f"macro `{node.name}`",
            )
        raise it.error(
            "E0232",
            f"macro `{node.name}` needs arguments",
            node.span,
            f"{node.name}({', '.join(v.params)})",
        )
    return v


def _warn_deprecated(it: BuildContext, node: syntax.Ident) -> None:
    note = it.deprecated[node.name]
    message, once, warned = note
    if once and warned:
        return
    note[2] = True
    it.sink.warning("W0402", message, node.span, f"`{node.name}` is deprecated")


def _e_const(it: BuildContext, node: syntax.Const) -> Any:
    for b in reversed(it.fn_bindings):
        if node.name in b:
            return b[node.name]
    if node.name in it.animation:
        return float(it.animation[node.name])
    if node.name == "now":
        it.depends_outside("now")
    return builtins.constant(
        node.name,
        clock=it.clock,
        version=it.version,
        image_width=it.image_width,
        image_height=it.image_height,
        input_file=Path(it.main_file).name,
    )


def _e_vector(it: BuildContext, node: syntax.Vector) -> Vec:
    comps = []
    for item in node.items:
        if type(item) in EXPRESSIONS:
            values = [(it.eval(item), item.span)]
        else:  # a directive: the components of the branch it takes
            values = [(e.value, e.span) for e in it.expand([item], None) if e.kind != "comma"]
        for v, span in values:
            if not isinstance(v, float | int):
                raise it.error(
                    "E0202", f"a vector component must be a float, not {describe(v)}", span
                )
            comps.append(v)
    if len(comps) < 2:
        raise it.error("E0202", "a vector needs 2 to 5 components", node.span)
    return Vec(comps)


def _e_unary(it: BuildContext, node: syntax.Unary) -> Any:
    return builtins.unary(node.op, it.eval(node.operand))


def _e_binary(it: BuildContext, node: syntax.Binary) -> Any:
    a = it.eval(node.left)
    if node.op == "&" and not builtins.truth(a):
        return 0.0
    if node.op == "|" and builtins.truth(a):
        return 1.0
    b = it.eval(node.right)
    try:
        return builtins.binary(node.op, a, b)
    except EvalError as e:
        return _lenient(it, e, node.span, lambda: builtins.divide_as_povray(a, b))


def _e_ternary(it: BuildContext, node: syntax.Ternary) -> Any:
    return it.eval(node.then if builtins.truth(it.eval(node.cond)) else node.other)


def _e_member(it: BuildContext, node: syntax.Member) -> Any:
    return builtins.member(it.eval(node.target), node.name)


def _e_index(it: BuildContext, node: syntax.Index) -> Any:
    base, chain = node.chain()
    arr = it.eval(base)
    if not isinstance(arr, ArrayValue):
        raise it.error("E0250", f"{describe(arr)} cannot be indexed", node.span)
    idx = array_index(it, arr, [it.eval(i) for i in chain], node.span)
    v = arr.data[arr.flat_index(tuple(idx))]
    if v is None:
        raise it.error(
            "E0250",
            "array element " + "".join(f"[{i}]" for i in idx) + " is not initialised",
            node.span,
        )
    return v


def array_index(it: BuildContext, arr: ArrayValue, raw: list[Any], span: Span) -> list[int]:
    if len(raw) != len(arr.dims):
        raise it.error(
            "E0250",
            f"the array has {len(arr.dims)} dimension(s); {len(raw)} index(es) given",
            span,
        )
    idx = []
    for r, d in zip(raw, arr.dims, strict=True):
        i = int(as_float(r, "an array index"))
        if not 0 <= i < d:
            raise it.error(
                "E0250",
                f"array index {i} is out of range 0..{d - 1}",
                span,
                f"this dimension has {d} element(s); indices start at 0",
            )
        idx.append(i)
    return idx


def _e_call(it: BuildContext, node: syntax.Call) -> Any:
    if node.builtin:
        if node.name == "defined":
            if len(node.args) == 1 and isinstance(node.args[0], syntax.Ident):
                return 1.0 if it.lookup(node.args[0].name)[0] else 0.0
            return 1.0
        if node.name in ("min_extent", "max_extent"):
            if len(node.args) != 1:
                raise it.error("E0203", f"{node.name}() takes one object", node.span)
            obj = it.eval(node.args[0])
            if not isinstance(obj, ObjectValue):
                raise it.error(
                    "E0202", f"{node.name}() needs an object, not {describe(obj)}", node.span
                )
            box = bounding_box(obj)
            if box is None:
                it.unsupported(f"{node.name}() of a `{obj.keyword}`", node.span)
                return Vec((0.0, 0.0, 0.0))
            return Vec(box[0] if node.name == "min_extent" else box[1])
        if node.name in ("inside", "trace"):
            return _geometry_call(it, node)
        if node.name == "vturbulence":
            return _vturbulence_call(it, node)
        if node.name in ("prod", "sum"):
            it.unsupported(f"{node.name}()", node.span)
            return 0.0
        args = [it.eval(a) for a in node.args]
        if node.name in ("acos", "asin") and len(args) == 1:
            args = [_clamped_domain(it, node, args[0])]
        try:
            return builtins.call(node.name, args, it.state)
        except EvalError as e:
            return _lenient(it, e, node.span, lambda: Vec((0.0, 0.0, 0.0)))
    found, v = it.lookup(node.name)
    if not found:
        raise it.unknown_ident(node.name, node.span)
    if isinstance(v, MacroValue):
        since = len(it.sink.items)
        els = it.call_macro(node)
        return it.single(els, node.span, f"macro `{node.name}`", since)
    if isinstance(v, FunctionValue):
        return it.call_function(v, [it.eval(a) for a in node.args], node.span)
    if isinstance(v, SplineValue):
        return _spline_call(it, v, node)
    if isinstance(v, UnsupportedValue):
        it.unsupported(v.keyword, node.span)
        return 0.0
    raise it.error("E0202", f"`{node.name}` is {describe(v)}, not a macro or function", node.span)


def _spline_call(it: BuildContext, v: SplineValue, node: syntax.Call) -> Any:
    """`S(t)`, or `S(t, linear_spline)`: the spline's points read as another kind (POV-Ray)."""
    args = node.args
    usage = "S(T) or S(T, linear_spline)"
    if not 1 <= len(args) <= 2:
        raise it.error("E0232", "a spline takes one parameter and maybe a kind", node.span, usage)
    if len(args) == 2:
        kind = args[1]
        if not isinstance(kind, syntax.Keyword) or kind.name not in schema.SPLINE_TYPES:
            raise it.error("E0202", "a spline's second argument is its kind", kind.span, usage)
        v = replace(v, spline_type=kind.name)
    return evaluate_spline(v, as_float(it.eval(args[0]), "a spline parameter"))


def _geometry_call(it: BuildContext, node: syntax.Call) -> Any:
    """POV-Ray's trace(OBJ, A, B [, N]) (the first point where the ray from A along B
    meets OBJ, <0,0,0> on a miss; N, when given, is set to the surface normal there, or
    <0,0,0>) and inside(OBJ, P) (1 or 0)."""
    name, args = node.name, node.args
    counts = (3, 4) if name == "trace" else (2,)
    if len(args) not in counts:
        want = " or ".join(map(str, counts))
        raise it.error("E0232", f"{name}() takes {want} arguments", node.span,
                         "trace(OBJECT, START, DIRECTION [, NORMAL])" if name == "trace"
                         else "inside(OBJECT, POINT)")  # fmt: skip
    if len(args) == 4 and not isinstance(args[3], syntax.Ident):
        raise it.error("E0202", "trace()'s fourth argument names a variable for the "
                         "normal", args[3].span)  # fmt: skip
    obj = it.eval(args[0])
    if not isinstance(obj, ObjectValue):
        raise it.error(
            "E0202", f"{name}() needs an object first, not {describe(obj)}", args[0].span
        )
    try:
        vecs = [as_vec(it.eval(a), 3, f"{name}()'s point").xyz for a in args[1:3]]
    except EvalError as e:
        raise it.error("E0203", e.message, node.span) from None
    queries = it.scene_queries()
    if queries is None:
        answer = "0" if name == "inside" else "<0, 0, 0>"
        it.warn_once(
            f"no-renderer:{name}()",
            f"{name}() called from the scene language gives {answer} here",
            node.span,
            "it needs the renderer's geometry: `strala render` computes it",
        )
    target = it.query_object(obj) if queries is not None else None
    if name == "inside":
        return 1.0 if queries is not None and queries.inside(target, vecs[0]) else 0.0
    found = queries.trace(target, vecs[0], vecs[1]) if queries is not None else None
    if queries is not None and trace_walk.step(
        queries, vecs[0], None if found is None else found[0]
    ):
        it.warn_once(
            "trace-walk",
            f"trace() has been called {trace_walk.CHAINED:,} times from next to its last hit: "
            "a walk over a surface, along which strala's intersections (equal to POV-Ray's "
            "but for the last bits) drift from POV-Ray's from step to step; what the walk "
            "builds may take other paths than in POV-Ray's render",
            node.span,
            "expected of a walk; a placement that starts each ray afresh is not affected",
        )
    point, normal = found if found is not None else ((0.0,) * 3, (0.0,) * 3)
    if len(args) == 4 and isinstance(normal_name := args[3], syntax.Ident):  # checked above
        it.declare(normal_name.name, Vec(normal), local=False)
    return Vec(point)


def _e_color(it: BuildContext, node: syntax.ColorCtor) -> ColorValue:
    if node.value is None:
        c = [0.0] * 5
    else:
        v = it.eval(node.value)
        kind = node.kind or ""
        base = kind.removeprefix("s")
        if kind == "":
            c = list(as_color(v, "a colour").rgbft)
        else:
            if isinstance(v, ColorValue):
                v = Vec(v.rgbft)
            n = {"rgb": 3, "rgbf": 4, "rgbt": 4, "rgbft": 5}[base]
            if isinstance(v, float | int):
                p = [float(v)] * n
            elif isinstance(v, Vec):
                p = [float(x) for x in v][:5]
                if len(p) > n:
                    # POV-Ray's Parse_Colour: the components given fill red, green, blue,
                    # filter, transmit in turn, however many the keyword names; fewer are
                    # padded with zeros
                    it.sink.warning("W0313", f"Suspicious expression after {kind}.", node.span)
            else:
                raise it.error("E0202", f"`{kind}` needs a vector, not {describe(v)}", node.span)
            c = (p + [0.0] * 5)[:5]
            if base == "rgbt":  # its fourth component is the transmit
                c[3], c[4] = 0.0, c[3]
            elif base == "rgb" and len(p) == 3:
                c[3] = c[4] = 0.0
            if kind.startswith("s"):
                c[:3] = [_from_srgb(it, x) for x in c[:3]]
    idx = {"red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4}
    for comp, expr in node.parts:
        val = as_float(it.eval(expr), f"`{comp}`")
        if comp in ("gray", "grey"):
            c[0] = c[1] = c[2] = val
        else:
            c[idx[comp]] = val
    return ColorValue(tuple(c))  # type: ignore[arg-type]


def _from_srgb(it: BuildContext, v: float) -> float:
    """sRGB-encoded → linear → the working gamma (assumed_gamma, 1.0 if unset)."""
    lin = v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4
    g = it.settings.get("assumed_gamma") or 1.0
    return lin ** (1.0 / g) if lin > 0 else lin


def _e_array(it: BuildContext, node: syntax.ArrayLit) -> ArrayValue:
    items = node.items
    dims = [int(as_float(it.eval(d), "an array size")) for d in node.dims]
    if not dims:
        # `array { … }`: the size comes from the initialiser (POV-Ray 3.8 style)
        dims = [len(items or [])]
    if any(d <= 0 for d in dims):
        raise it.error("E0250", "array sizes must be positive", node.span)
    total = 1
    for d in dims:
        total *= d
    if total > MAX_ARRAY_ELEMENTS:
        raise it.error(
            "E0250",
            f"an array of {total:,} elements is too large",
            node.span,
            f"strala's arrays hold at most {MAX_ARRAY_ELEMENTS:,} elements",
        )
    it.meter.reserve(total * ARRAY_SLOT_BYTES)
    arr = ArrayValue(tuple(dims), [None] * total)
    if items is not None:
        flat: list[Any] = []

        def walk(level: list, depth: int) -> None:
            want = dims[depth] if depth < len(dims) else 0
            if len(level) != want:
                raise it.error(
                    "E0250",
                    f"the array initialiser has {len(level)} item(s) at depth {depth + 1}, "
                    f"the array declares {want}",
                    node.span,
                )
            for item in level:
                if isinstance(item, list):
                    walk(item, depth + 1)
                else:
                    if depth != len(dims) - 1:
                        raise it.error("E0250", "the array initialiser is too shallow", node.span)
                    flat.append(it.eval_value(item))

        walk(list(items), 0)
        arr.data = flat
    return arr


def _e_block(it: BuildContext, node: syntax.Block) -> Any:
    return it.eval_block(node)


# How each kind of expression node evaluates.
EXPRESSIONS: dict[type, Callable[[BuildContext, Any], Any]] = {
    syntax.Number: _e_number,
    syntax.String: _e_string,
    syntax.Ident: _e_ident,
    syntax.Const: _e_const,
    syntax.Vector: _e_vector,
    syntax.Unary: _e_unary,
    syntax.Binary: _e_binary,
    syntax.Ternary: _e_ternary,
    syntax.Member: _e_member,
    syntax.Index: _e_index,
    syntax.Call: _e_call,
    syntax.ColorCtor: _e_color,
    syntax.ArrayLit: _e_array,
    syntax.Block: _e_block,
}


def _vturbulence_call(it: BuildContext, node) -> Vec:
    """POV-Ray's DTurbulence at a point, from the renderer's noise (lang cannot compute it)."""
    try:
        lam, omega, octaves, point = builtins.vturbulence_args([it.eval(a) for a in node.args])
    except EvalError as e:
        raise it.error("E0203", e.message, node.span, e.hint) from None
    queries = it.scene_queries("vturbulence()")
    if queries is None:
        it.warn_once(
            "no-renderer:vturbulence()",
            "vturbulence() called from the scene language gives <0, 0, 0> here",
            node.span,
            "its value needs the renderer's noise: `strala render` computes it",
        )
        return Vec((0.0, 0.0, 0.0))
    return Vec(queries.vturbulence(lam, omega, octaves, (point[0], point[1], point[2])))


def _lenient(it: BuildContext, e: EvalError, span, repaired: Callable[[], Any]) -> Any:
    """An evaluation error that POV-Ray repairs with a warning gives its repair; any other
    is the located error E0203. A zero divisor gives infinity (express.cpp,
    Parse_Mult_Factor: "Divide by zero."), vnormalize(<0,0,0>) the zero vector
    (Parse_Vector_Factor: "Normalizing zero-length vector.", a possible error)."""
    if e.message == builtins.ZERO_DIVISION:
        it.sink.warning("W0309", "Divide by zero.", span, "POV-Ray makes the quotient infinite")
        return repaired()
    if e.message == builtins.ZERO_NORMALIZE:
        it.sink.warning("W0309", "Normalizing zero-length vector.", span, "POV-Ray gives <0,0,0>")
        return repaired()
    raise it.error("E0203", e.message, span, e.hint) from None


def _clamped_domain(it: BuildContext, node: syntax.Call, v: Any) -> Any:
    """POV-Ray's acos and asin (express.cpp, Parse_Num_Factor) warn "Domain error in acos."
    for an argument outside [-1, 1] and use the nearer end (acos(1.0000001) from rounding in
    a dot product is common); only a float is clamped, anything else errors as before."""
    if not isinstance(v, float | int) or -1.0 <= v <= 1.0:
        return v
    it.sink.warning(
        "W0309",
        f"Domain error in {node.name}.",
        node.span,
        "POV-Ray uses the nearer of -1 and 1 and renders the same",
    )
    return 1.0 if v > 1.0 else -1.0


# ---------------------------------------------------------------- compiled expressions
# An operator, a call of a built-in function or a negation is turned into a closure the
# first time it is evaluated, with its operands' closures inside: a loop body's arithmetic
# then runs without the tree walk's dispatch per node. A closure does exactly what
# Interpreter.eval does for its node (an EvalError becomes E0203 at the node's span; the
# operands' errors at theirs); kinds without a closure of their own go through it.eval.
Compiled = Callable[[BuildContext], Any]
# built-ins that look at their arguments' syntax or the scene, not only at their values,
# or warn (acos and asin outside [-1, 1]), or ask the renderer (vturbulence): the tree walk
# evaluates them
_SPECIAL_CALLS = frozenset(
    "defined min_extent max_extent inside trace prod sum acos asin vturbulence".split()
)


# evaluations of an expression before it is made a generated function (lang.eval.generated):
# making one costs as much as a few hundred evaluations save
GENERATE_AFTER = 200


def compiled(node: syntax.Node) -> Compiled | None:
    """The closure of an expression evaluated more than once: for an operator, unary
    operator or built-in call, its closure (_closure), which turns into the expression's
    generated function once it has run GENERATE_AFTER times; for a vector, member, index
    or ternary of the pure subset, the tree walk until then. None for anything else."""
    slow = _closure(node)
    if slow is None:
        if type(node) not in _WALKED or not generated.pure(node):
            return None
        slow = walker(node)
    elif not generated.pure(node):
        return slow
    fast: Compiled | None = None
    runs = 0

    def warming(it: BuildContext) -> Any:
        nonlocal fast, runs
        if fast is not None:
            try:
                return fast(it)
            except Exception:  # anything unusual: the usual way reports it where it occurs
                return slow(it)
        runs += 1
        if runs == GENERATE_AFTER:
            fast = generated.function(node, _e_const)
        return slow(it)

    return warming


_WALKED = frozenset({syntax.Vector, syntax.Member, syntax.Index, syntax.Ternary})


def walker(node: syntax.Node) -> Compiled:
    """The tree walk of one node, as Interpreter.eval does it (an EvalError located at it)."""
    walk = EXPRESSIONS[type(node)]

    def walked(it: BuildContext) -> Any:
        try:
            return walk(it, node)
        except EvalError as e:
            raise it.error("E0203", e.message, node.span, e.hint) from None

    return walked


def _closure(node: syntax.Node) -> Compiled | None:
    """The closure of an operator, unary operator or built-in call; None for other nodes."""
    if isinstance(node, syntax.Binary):
        return _compile_binary(node)
    if isinstance(node, syntax.Unary):
        return _compile_unary(node)
    if isinstance(node, syntax.Call) and node.builtin and node.name not in _SPECIAL_CALLS:
        return _compile_call(node)
    return None


def _operand(node: syntax.Node) -> Compiled:
    if isinstance(node, syntax.Number):
        value = node.value
        return lambda it: value
    if isinstance(node, syntax.Ident):
        return _compile_ident(node)
    return _closure(node) or (lambda it: it.eval(node))


def _compile_ident(node: syntax.Ident) -> Compiled:
    name = node.name

    def ident(it: BuildContext) -> Any:
        found, v = it.lookup(name)
        if not found or isinstance(v, MacroValue) or (it.deprecated and name in it.deprecated):
            return it.eval(node)  # the rare cases, as the tree walk handles them
        return v

    return ident


def _compile_binary(node: syntax.Binary) -> Compiled:
    left, right, op, span = _operand(node.left), _operand(node.right), node.op, node.span
    fast = builtins.FLOAT_OPS.get(op)
    truth = builtins.truth

    def binary(it: BuildContext) -> Any:
        try:
            a = left(it)
            if op == "&" and not truth(a):
                return 0.0
            if op == "|" and truth(a):
                return 1.0
            b = right(it)
            if fast is not None and type(a) is float and type(b) is float:
                return fast(a, b)
            return builtins.binary(op, a, b)
        except EvalError as e:
            return _lenient(it, e, span, lambda: builtins.divide_as_povray(a, b))

    return binary


def _compile_unary(node: syntax.Unary) -> Compiled:
    operand, op, span = _operand(node.operand), node.op, node.span

    def unary(it: BuildContext) -> Any:
        try:
            return builtins.unary(op, operand(it))
        except EvalError as e:
            raise it.error("E0203", e.message, span, e.hint) from None

    return unary


def _compile_call(node: syntax.Call) -> Compiled:
    args, name, span = [_operand(a) for a in node.args], node.name, node.span
    call = builtins.call

    def builtin(it: BuildContext) -> Any:
        try:
            return call(name, [a(it) for a in args], it.state)
        except EvalError as e:
            return _lenient(it, e, span, lambda: Vec((0.0, 0.0, 0.0)))

    return builtin
