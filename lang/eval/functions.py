"""User functions: a `function { … }` body (syntax) becomes an `ir.Function` (an Fn… tree).

POV-Ray binds a function's free names when it is declared: every declared float, vector
member or array element it names is folded into a number here, so a later `#declare` of
the same name does not change the function. Parameters (x, y, z unless the function lists
its own) stay symbolic. Unknown names and wrong argument counts are reported at their span.

The same tree serves both sides: `call` evaluates it for one set of scalar arguments (a
function called from the scene language, `F(1, 2, 3)`), `runtime.functions` compiles it
to numpy for the renderer. This module imports no numpy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from lang import builtins, ir, syntax
from lang.builtins import EvalError
from lang.diagnostics import Span
from lang.eval.splines import cubic_pieces, spline_piece_value
from lang.values import ArrayValue, FunctionValue, MacroValue, SplineValue, Vec, describe

if TYPE_CHECKING:
    from lang.eval.context import BuildContext

# Built-in float functions a function body may call: name -> (min args, max args or None).
FN_BUILTINS: dict[str, tuple[int, int | None]] = {
    **{
        n: (1, 1)
        for n in """abs acos acosh asin asinh atan atanh ceil cos cosh degrees exp floor int
        ln log radians sin sinh sqrt sqr tan tanh""".split()
    },
    "atan2": (2, 2),
    "pow": (2, 2),
    "mod": (2, 2),
    "div": (2, 2),
    "min": (1, None),
    "max": (1, None),
    "select": (3, 4),
}

# POV-Ray's render-time built-in functions, by their `internal(N)` number: (name, number of
# parameters after x, y, z). functions.inc gives each a name (f_sphere = internal(61) …).
INTERNALS: tuple[tuple[str, int], ...] = (
    ("f_algbr_cyl1", 5), ("f_algbr_cyl2", 5), ("f_algbr_cyl3", 5), ("f_algbr_cyl4", 5),
    ("f_bicorn", 2), ("f_bifolia", 2), ("f_blob", 5), ("f_blob2", 4), ("f_boy_surface", 2),
    ("f_comma", 1), ("f_cross_ellipsoids", 4), ("f_crossed_trough", 1),
    ("f_cubic_saddle", 1), ("f_cushion", 1), ("f_devils_curve", 1),
    ("f_devils_curve_2d", 6), ("f_dupin_cyclid", 6), ("f_ellipsoid", 3), ("f_enneper", 1),
    ("f_flange_cover", 4), ("f_folium_surface", 3), ("f_folium_surface_2d", 6),
    ("f_glob", 1), ("f_heart", 1), ("f_helical_torus", 10), ("f_helix1", 7),
    ("f_helix2", 7), ("f_hex_x", 1), ("f_hex_y", 1), ("f_hetero_mf", 6),
    ("f_hunt_surface", 1), ("f_hyperbolic_torus", 3), ("f_isect_ellipsoids", 4),
    ("f_kampyle_of_eudoxus", 3), ("f_kampyle_of_eudoxus_2d", 6), ("f_klein_bottle", 1),
    ("f_kummer_surface_v1", 1), ("f_kummer_surface_v2", 4), ("f_lemniscate_of_gerono", 1),
    ("f_lemniscate_of_gerono_2d", 6), ("f_mesh1", 5), ("f_mitre", 1), ("f_nodal_cubic", 1),
    ("f_odd", 1), ("f_ovals_of_cassini", 4), ("f_paraboloid", 1), ("f_parabolic_torus", 3),
    ("f_ph", 0), ("f_pillow", 1), ("f_piriform", 1), ("f_piriform_2d", 7), ("f_poly4", 5),
    ("f_polytubes", 6), ("f_quantum", 1), ("f_quartic_paraboloid", 1),
    ("f_quartic_saddle", 1), ("f_quartic_cylinder", 3), ("f_r", 0), ("f_ridge", 6),
    ("f_ridged_mf", 6), ("f_rounded_box", 4), ("f_sphere", 1), ("f_spikes", 5),
    ("f_spikes_2d", 4), ("f_spiral", 6), ("f_steiners_roman", 1), ("f_strophoid", 4),
    ("f_strophoid_2d", 7), ("f_superellipsoid", 2), ("f_th", 0), ("f_torus", 2),
    ("f_torus2", 3), ("f_torus_gumdrop", 1), ("f_umbrella", 1), ("f_witch_of_agnesi", 2),
    ("f_witch_of_agnesi_2d", 6), ("f_noise3d", 0), ("f_pattern", 0),
    ("f_noise_generator", 1),
)  # fmt: skip

_COMPONENTS = {
    "red": 0, "green": 1, "blue": 2, "filter": 3, "transmit": 4, "gray": 5, "grey": 5,
    "x": 0, "y": 1, "z": 2, "t": 3, "u": 0, "v": 1, "rgb": 5,
}  # fmt: skip


def build(it: BuildContext, node: syntax.Block) -> FunctionValue | SplineValue:
    """The FunctionValue of a `function [(params)] { body }` block, or of a `function W, H
    { body }` image (height_field, image_map …): the sizes lead its body. POV-Ray's spline
    function, `function { spline { … } }`, is the spline: called as F(t), it gives the
    spline's value at t."""
    body = [n for n in node.body if not isinstance(n, syntax.Comma)]
    if node.params is None and len(body) == 1 and isinstance(body[0], syntax.Block):
        if body[0].keyword == "spline":
            spline = it.eval_block(body[0])
            assert isinstance(spline, SplineValue)  # what a spline block evaluates to
            return spline
    params = tuple(node.params) if node.params is not None else ("x", "y", "z")
    size = None
    head = [n for n in node.body[:3] if not isinstance(n, syntax.Comma)][:2]
    if (
        node.params is None
        and len(head) == 2
        and len(node.body) > 2
        and all(isinstance(n, syntax.Number | syntax.Ident) for n in head)
    ):
        size = (_image_size(it, head[0]), _image_size(it, head[1]))
        at = next(i for i, n in enumerate(node.body) if n is head[1])
        rest = node.body[at + 1 :]
        node = syntax.Block(node.span, node.keyword, rest, None, node.keyword_span)
    fn = _Builder(it, params).function(node)
    return FunctionValue(fn.params, tuple(node.body), node.span, compiled=fn, size=size)


def _image_size(it: BuildContext, node: syntax.Node) -> int:
    """A size of a function image in pixels: a float rounded as POV-Ray rounds it (at least 2)."""
    v = it.eval(node)
    if not isinstance(v, bool | int | float):
        raise it.error("E0240", f"an image size is a number, not {describe(v)}", node.span)
    n = int(float(v) + 0.5)
    if n < 2:
        msg = f"a function image needs at least 2 pixels a side, got {n}"
        raise it.error("E0240", msg, node.span)
    return n


# Other names of the default parameters x and y (a parametric's functions of u and v).
_UV = {"u": 0, "v": 1}


class _Builder:
    def __init__(self, it: BuildContext, params: tuple[str, ...]):
        self.it = it
        self.params = params

    def error(self, msg: str, span: Span, hint: str | None = None) -> Exception:
        return self.it.error("E0240", msg, span, hint)

    def function(self, node: syntax.Block) -> ir.Function:
        body = [n for n in node.body if not isinstance(n, syntax.Comma)]
        span = node.keyword_span or node.span
        if len(body) == 2 and isinstance(body[0], syntax.Keyword) and body[0].name == "internal":
            number = self.it.eval(body[1])
            k = int(number) if isinstance(number, float | int) else -1
            if not 0 <= k < len(INTERNALS) or INTERNALS[k][0] == "f_pattern":
                raise self.error(f"there is no internal function {number!r}", body[1].span)
            name, n = INTERNALS[k]
            params = ("x", "y", "z", *(f"P{i}" for i in range(n)))
            args = tuple(ir.FnArg(i, p) for i, p in enumerate(params))
            return ir.Function(params, ir.FnInternal(name, args), "float", node.span)
        if len(body) == 1 and isinstance(body[0], syntax.Block):
            inner = body[0]
            xyz = (ir.FnArg(0, "x"), ir.FnArg(1, "y"), ir.FnArg(2, "z"))
            if inner.keyword in ("pattern", "pigment"):
                as_pigment = syntax.Block(
                    inner.span, "pigment", inner.body, None, inner.keyword_span
                )
                pig = self.it.eval_block(as_pigment)
                if inner.keyword == "pattern":
                    return ir.Function(("x", "y", "z"), ir.FnPattern(pig, xyz), "float", node.span)
                return ir.Function(("x", "y", "z"), ir.FnPigment(pig, xyz), "pigment", node.span)
            self.it.unsupported(f"function {{ {inner.keyword} }}", inner.keyword_span or span)
            return ir.Function(self.params, ir.FnNum(0.0), "float", node.span)
        if len(body) != 1:
            raise self.error(
                "a function's body is one expression",
                span,
                "function { x*x + y*y - 1 } or function { pattern { … } }",
            )
        return ir.Function(self.params, self.expr(body[0]), "float", node.span)

    # ---------------------------------------------------------------- expressions
    def expr(self, node: syntax.Node) -> Any:
        t = type(node)
        n: Any = node  # dispatched on its exact type, which mypy cannot follow
        if t is syntax.Number:
            return ir.FnNum(float(n.value))
        if t is syntax.Const or t is syntax.Ident:
            if n.name in self.params:
                return ir.FnArg(self.params.index(n.name), n.name)
            if n.name in _UV and self.params == ("x", "y", "z"):
                # POV-Ray's default parameters: u and v are the first two, x and y
                return ir.FnArg(_UV[n.name], n.name)
            return self.constant(n)
        if t is syntax.Unary:
            a = self.expr(n.operand)
            return _fold(ir.FnUnary(n.op, a))
        if t is syntax.Binary:
            return _fold(ir.FnBinary(n.op, self.expr(n.left), self.expr(n.right)))
        if t is syntax.Ternary:
            return _fold(ir.FnCond(self.expr(n.cond), self.expr(n.then), self.expr(n.other)))
        if t is syntax.Call:
            return self.call(n)
        if t is syntax.Member:
            return self.member(n)
        if t is syntax.Index:
            return self.constant(n)
        if t is syntax.Vector:
            raise self.error("a function's value is a float, not a vector", n.span)
        raise self.error("this cannot be used in a function", n.span)

    def constant(self, node: syntax.Node) -> ir.FnNum:
        """A name or value outside the parameters: its value now, which must be a float."""
        if isinstance(node, syntax.Ident):
            found, v = self.it.lookup(node.name)
            if not found:
                raise self.it.unknown_ident(node.name, node.span)
            if isinstance(v, FunctionValue | MacroValue):
                raise self.error(f"`{node.name}` needs arguments here", node.span)
        v = self.it.eval(node)
        if isinstance(v, bool | int | float):
            return ir.FnNum(float(v))
        name = getattr(node, "name", None)
        what = f"`{name}` is {describe(v)}" if name else f"this is {describe(v)}"
        hint = "x, y and z are the function's parameters" if name in ("x", "y", "z") else None
        raise self.error(f"{what}; a function works with floats", node.span, hint)

    def spline_of_parameters(self, node: syntax.Call) -> bool:
        """Whether `node` calls a spline with a parameter of the function (not computed)."""
        if node.builtin:
            return False
        found, v = self.it.lookup(node.name)
        if not found or not isinstance(v, SplineValue):
            return False
        values = [self.expr(a) for a in node.args if not isinstance(a, syntax.Keyword)]
        return not all(isinstance(a, ir.FnNum) for a in values)

    def spline_at(self, node: syntax.Call, component: int) -> ir.FnSpline:
        """`S(t)` of a parameter: the spline's component as pieces."""
        _, sp = self.it.lookup(node.name)
        if len(node.args) != 1:
            # POV-Ray: a spline read as another kind, S(t, kind), is for the scene language
            raise self.it.error("E0232", "a spline in a function takes one parameter", node.span)
        knots, coeffs = cubic_pieces(sp, component)
        return ir.FnSpline(knots, coeffs, self.expr(node.args[0]))

    def call(self, node: syntax.Call) -> Any:
        if self.spline_of_parameters(node):
            return self.spline_at(node, 0)
        args = tuple(self.expr(a) for a in node.args)
        if node.builtin:
            arity = FN_BUILTINS.get(node.name)
            if arity is None:
                if all(isinstance(a, ir.FnNum) for a in args):
                    return self.constant(node)
                raise self.error(f"`{node.name}()` cannot be used in a function", node.span)
            lo, hi = arity
            if len(args) < lo or (hi is not None and len(args) > hi):
                want = f"{lo}" if hi == lo else (f"{lo} or more" if hi is None else f"{lo} to {hi}")
                raise self.it.error(
                    "E0232", f"{node.name}() takes {want} argument(s), got {len(args)}", node.span
                )
            return _fold(ir.FnBuiltin(node.name, args))
        found, v = self.it.lookup(node.name)
        if not found:
            raise self.it.unknown_ident(node.name, node.span)
        if isinstance(v, FunctionValue):
            fn = v.compiled
            if fn is None:
                raise self.error(f"`{node.name}` cannot be used in a function", node.span)
            if len(args) != len(fn.params):
                raise self.it.error(
                    "E0232",
                    f"`{node.name}` takes {len(fn.params)} argument(s), got {len(args)}",
                    node.span,
                    f"{node.name}({', '.join(fn.params)})",
                )
            if fn.kind == "pigment":
                return _pigment_at(fn, args, 5)
            return _fold(ir.FnCall(fn, args))
        if isinstance(v, ArrayValue | Vec) or not isinstance(v, MacroValue):
            if all(isinstance(a, ir.FnNum) for a in args):
                return self.constant(node)  # a spline or similar at a fixed point
        raise self.error(f"`{node.name}` ({describe(v)}) cannot be used in a function", node.span)

    def member(self, node: syntax.Member) -> Any:
        target = node.target
        if isinstance(target, syntax.Call) and self.spline_of_parameters(target):
            component = _SPLINE_COMPONENTS.get(node.name)
            if component is None:
                raise self.error(f"a spline's value has no `.{node.name}`", node.span)
            return self.spline_at(target, component)
        if isinstance(target, syntax.Call) and not target.builtin:
            found, v = self.it.lookup(target.name)
            if found and isinstance(v, FunctionValue) and v.compiled is not None:
                if v.compiled.kind == "pigment":
                    comp = _COMPONENTS.get(node.name)
                    if comp is None:
                        raise self.error(f"a colour has no `.{node.name}`", node.span)
                    call = self.call(target)
                    return _pigment_at(v.compiled, call.args, comp)
        return self.constant(node)


# A spline's value is a float or a vector of up to five components (POV-Ray's x y z t,
# u v as x y, and colours' red … transmit).
_SPLINE_COMPONENTS = {
    "x": 0, "u": 0, "red": 0, "y": 1, "v": 1, "green": 1, "z": 2, "blue": 2,
    "t": 3, "filter": 3, "transmit": 4,
}  # fmt: skip


def _pigment_at(fn: ir.Function, args: tuple[Any, ...], component: int) -> ir.FnPigment:
    """A pigment function's colour component at `args` (its body is FnPigment at x, y, z)."""
    body = fn.body
    assert isinstance(body, ir.FnPigment)
    return ir.FnPigment(body.pigment, (args[0], args[1], args[2]), component)


def _fold(e: Any) -> Any:
    """A node whose operands are all numbers becomes a number (when it has one)."""
    kids = _operands(e)
    if kids and all(isinstance(k, ir.FnNum) for k in kids):
        try:
            value = evaluate(e, ())
        except (EvalError, ArithmeticError, ValueError, Unevaluable):
            return e  # left for the runtime (NaN or inf there, as POV-Ray's VM)
        return ir.FnNum(value)
    return e


def _operands(e: Any) -> tuple[Any, ...]:
    if isinstance(e, ir.FnUnary):
        return (e.a,)
    if isinstance(e, ir.FnBinary):
        return (e.a, e.b)
    if isinstance(e, ir.FnCond):
        return (e.cond, e.then, e.other)
    if isinstance(e, ir.FnBuiltin | ir.FnCall):
        return e.args
    if isinstance(e, ir.FnSpline):
        return (e.arg,)
    return ()


# ------------------------------------------------------------------ scalar evaluation
class Unevaluable(Exception):
    """The function needs the renderer (a pattern, pigment or internal function)."""

    def __init__(self, what: str):
        super().__init__(what)
        self.what = what


def call(fn: ir.Function, args: tuple[float, ...]) -> float:
    """fn(args) in plain Python floats (raises EvalError on a domain error)."""
    return evaluate(fn.body, args)


def evaluate(e: Any, args: tuple[float, ...]) -> float:
    t = type(e)
    if t is ir.FnNum:
        return e.value
    if t is ir.FnArg:
        return args[e.index]
    if t is ir.FnUnary:
        return builtins.unary(e.op, evaluate(e.a, args))
    if t is ir.FnBinary:
        a = evaluate(e.a, args)
        if e.op == "&" and a == 0.0:
            return 0.0
        if e.op == "|" and a != 0.0:
            return 1.0
        return builtins.binary(e.op, a, evaluate(e.b, args))
    if t is ir.FnCond:
        return evaluate(e.then if evaluate(e.cond, args) != 0.0 else e.other, args)
    if t is ir.FnBuiltin:
        vals = [evaluate(a, args) for a in e.args]
        return float(builtins.call(e.name, vals, _NO_STATE))
    if t is ir.FnCall:
        return evaluate(e.fn.body, tuple(evaluate(a, args) for a in e.args))
    if t is ir.FnSpline:
        return spline_piece_value(e, evaluate(e.arg, args))
    if t is ir.FnInternal:
        raise Unevaluable(f"{e.name}()")
    if t is ir.FnPattern:
        raise Unevaluable("a pattern function")
    if t is ir.FnPigment:
        raise Unevaluable("a pigment function")
    raise EvalError(f"not a function expression: {t.__name__}")


class _NoState:
    """Function bodies call no stateful built-ins (rand and seed are not allowed)."""


_NO_STATE: Any = _NoState()
