"""Expressions as generated Python functions: a loop's or a macro's arithmetic at the speed
of Python itself.

An expression made only of pure parts (numbers, strings, names, vectors, operators, member
and index access, the ternary, the built-in constants and the built-in functions that read
nothing but their arguments) becomes the source of one Python function, compiled once:
values in local variables, floats combined inline, everything else through the very
functions the tree walk calls (lang.builtins). Nothing it does is seen outside (no
diagnostic, no random stream, no file), so when anything is out of the ordinary (a name
not found or deprecated, a macro, a division by zero, a type error, any exception) the
function gives up and the expression is evaluated again the usual way
(lang.eval.expressions), which reports it exactly where the tree walk does. Names are
looked up as Interpreter.lookup does (innermost scope first; a name read is marked used).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from lang import builtins, syntax
from lang.animation import NAMES as ANIMATION_NAMES
from lang.values import ArrayValue, MacroValue, Vec

Generated = Callable[[Any], Any]


class GiveUp(Exception):
    """The generated function cannot give this value: evaluate the expression the usual way."""


# Built-in functions that read nothing but their arguments and report nothing (rand and
# seed move a stream, file_exists looks outside, the rest of _SPECIAL reads syntax or warns).
_IMPURE = frozenset({"rand", "seed", "file_exists"})
_SPECIAL = frozenset(
    "defined min_extent max_extent inside trace prod sum vturbulence acos asin".split()
)
# operators on two floats written inline (the same formulas as builtins.FLOAT_OPS)
_INLINE = {"+": "+", "-": "-", "*": "*"}
_VEC_INDEX = {"x": 0, "u": 0, "y": 1, "v": 1, "z": 2, "t": 3}
MAX_NODES = 400  # a larger expression is not worth a function of its own


class _Unsupported(Exception):
    """A node outside the pure subset: no function for this expression."""


def _give_up() -> None:
    raise GiveUp()


def _index(arr: Any, raw: tuple[Any, ...]) -> Any:
    """arr[raw…] when every index is a float in range and the element is set."""
    if type(arr) is not ArrayValue or len(raw) != len(arr.dims):
        raise GiveUp()
    n = 0
    for r, d in zip(raw, arr.dims, strict=True):
        if type(r) is not float:
            raise GiveUp()
        i = int(r)
        if not 0 <= i < d:
            raise GiveUp()
        n = n * d + i
    v = arr.data[n]
    if v is None:
        raise GiveUp()
    return v


class _Writer:
    def __init__(self) -> None:
        self.lines: list[str] = []
        self.consts: dict[str, Any] = {}
        self.names: set[str] = set()  # identifiers read (for the deprecation check)
        self.count = 0
        self.depth = 1
        self.uses_constants = False

    def temp(self) -> str:
        self.count += 1
        return f"v{self.count}"

    def const(self, value: Any) -> str:
        name = f"k{len(self.consts)}"
        self.consts[name] = value
        return name

    def emit(self, line: str) -> None:
        self.lines.append("    " * self.depth + line)

    # ---------------------------------------------------------------- nodes
    def node(self, n: syntax.Node, memo: dict[str, str]) -> str:
        t = type(n)
        if t is syntax.Number or t is syntax.String:
            return self.const(n.value)  # type: ignore[attr-defined]
        if t is syntax.Ident:
            return self.ident(n.name, memo)  # type: ignore[attr-defined]
        if t is syntax.Const:
            return self.constant(n)  # type: ignore[arg-type]
        if t is syntax.Binary:
            return self.binary(n, memo)  # type: ignore[arg-type]
        if t is syntax.Unary:
            return self.unary(n, memo)  # type: ignore[arg-type]
        if t is syntax.Call:
            return self.call(n, memo)  # type: ignore[arg-type]
        if t is syntax.Vector:
            return self.vector(n, memo)  # type: ignore[arg-type]
        if t is syntax.Member:
            return self.member(n, memo)  # type: ignore[arg-type]
        if t is syntax.Index:
            return self.index(n, memo)  # type: ignore[arg-type]
        if t is syntax.Ternary:
            return self.ternary(n, memo)  # type: ignore[arg-type]
        raise _Unsupported()

    def ident(self, name: str, memo: dict[str, str]) -> str:
        hit = memo.get(name)
        if hit is not None:
            return hit
        self.names.add(name)
        v, key = self.temp(), self.const(name)
        self.emit("for s in reversed(scopes):")
        self.emit(f"    if {key} in s:")
        self.emit(f"        {v} = s[{key}]")
        self.emit("        break")
        self.emit("else:")
        self.emit("    give_up()")
        self.emit(f"if type({v}) is not float and isinstance({v}, MacroValue):")
        self.emit("    give_up()")
        self.emit(f"used({key})")
        memo[name] = v
        return v

    def constant(self, n: syntax.Const) -> str:
        self.uses_constants = True  # a function's x, y, z shadow them: see the prologue
        if n.name in builtins.FIXED_CONSTANTS and n.name not in ANIMATION_NAMES:
            return self.const(builtins.FIXED_CONSTANTS[n.name])
        if n.name == "now":
            raise _Unsupported()  # the result then depends on the time
        v = self.temp()
        self.emit(f"{v} = const(it, {self.const(n)})")
        return v

    def binary(self, n: syntax.Binary, memo: dict[str, str]) -> str:
        a = self.node(n.left, memo)
        v, op = self.temp(), n.op
        opk = self.const(op)
        if op in ("&", "|"):
            # the right operand only when the left one does not decide
            self.emit(f"t = ({a} != 0.0) if type({a}) is float else truth({a})")
            self.emit("if not t:" if op == "&" else "if t:")
            self.emit(f"    {v} = {'0.0' if op == '&' else '1.0'}")
            self.emit("else:")
            self.depth += 1
            b = self.node(n.right, dict(memo))
            self.emit(f"if type({a}) is float and type({b}) is float:")
            self.emit(f"    {v} = fast[{opk}]({a}, {b})")
            self.emit("else:")
            self.emit(f"    {v} = binary({opk}, {a}, {b})")
            self.depth -= 1
            return v
        b = self.node(n.right, memo)
        self.emit(f"if type({a}) is float and type({b}) is float:")
        if op in _INLINE:
            self.emit(f"    {v} = {a} {_INLINE[op]} {b}")
        elif op == "/":
            self.emit(f"    {v} = {a} / {b}")  # ZeroDivisionError: the usual way warns
        else:
            self.emit(f"    {v} = fast[{opk}]({a}, {b})")
        self.emit("else:")
        self.emit(f"    {v} = binary({opk}, {a}, {b})")
        return v

    def unary(self, n: syntax.Unary, memo: dict[str, str]) -> str:
        a = self.node(n.operand, memo)
        v = self.temp()
        if n.op == "-":
            self.emit(f"{v} = -{a} if type({a}) is float else unary('-', {a})")
        else:
            self.emit(f"{v} = unary({self.const(n.op)}, {a})")
        return v

    def call(self, n: syntax.Call, memo: dict[str, str]) -> str:
        if not n.builtin or n.name in _IMPURE:
            raise _Unsupported()
        if n.name == "defined":
            v = self.temp()
            if len(n.args) == 1 and isinstance(n.args[0], syntax.Ident):
                key = self.const(n.args[0].name)
                self.emit(f"{v} = 0.0")
                self.emit("for s in reversed(scopes):")
                self.emit(f"    if {key} in s:")
                self.emit(f"        {v} = 1.0")
                self.emit(f"        used({key})")
                self.emit("        break")
            else:
                self.emit(f"{v} = 1.0")
            return v
        entry = builtins.FUNCTIONS.get(n.name)
        if entry is None or n.name in _SPECIAL and n.name not in ("acos", "asin"):
            raise _Unsupported()
        fn, lo, hi = entry
        if len(n.args) < lo or (hi is not None and len(n.args) > hi):
            raise _Unsupported()  # the usual way says how to call it
        args = [self.node(a, memo) for a in n.args]
        if n.name in ("acos", "asin"):
            # outside [-1, 1] POV-Ray warns and clamps: the usual way does that
            self.emit(f"if type({args[0]}) is not float or not -1.0 <= {args[0]} <= 1.0:")
            self.emit("    give_up()")
        v = self.temp()
        self.emit(f"{v} = {self.const(fn)}([{', '.join(args)}], state)")
        return v

    def vector(self, n: syntax.Vector, memo: dict[str, str]) -> str:
        if len(n.items) < 2:
            raise _Unsupported()
        comps = [self.node(item, memo) for item in n.items]
        self.emit("if " + " or ".join(f"type({c}) is not float" for c in comps) + ":")
        self.emit("    give_up()")
        v = self.temp()
        self.emit(f"{v} = vec(({', '.join(comps)},))")
        return v

    def member(self, n: syntax.Member, memo: dict[str, str]) -> str:
        a = self.node(n.target, memo)
        v = self.temp()
        i = _VEC_INDEX.get(n.name)
        key = self.const(n.name)
        if i is not None:
            self.emit(f"if type({a}) is Vec and len({a}) > {i}:")
            self.emit(f"    {v} = {a}[{i}]")
            self.emit("else:")
            self.emit(f"    {v} = member({a}, {key})")
        else:
            self.emit(f"{v} = member({a}, {key})")
        return v

    def index(self, n: syntax.Index, memo: dict[str, str]) -> str:
        base, chain = n.chain()
        arr = self.node(base, memo)
        idx = [self.node(i, memo) for i in chain]
        v = self.temp()
        self.emit(f"{v} = index({arr}, ({', '.join(idx)},))")
        return v

    def ternary(self, n: syntax.Ternary, memo: dict[str, str]) -> str:
        c = self.node(n.cond, memo)
        v = self.temp()
        self.emit(f"if ({c} != 0.0) if type({c}) is float else truth({c}):")
        self.depth += 1
        a = self.node(n.then, dict(memo))
        self.emit(f"{v} = {a}")
        self.depth -= 1
        self.emit("else:")
        self.depth += 1
        b = self.node(n.other, dict(memo))
        self.emit(f"{v} = {b}")
        self.depth -= 1
        return v


def _size(node: syntax.Node) -> int:
    return sum(1 for _ in syntax.walk(node))


def pure(node: syntax.Node) -> bool:
    """Whether `node` is in the pure subset (no function is made for it yet)."""
    try:
        _Writer().node(node, {})
    except _Unsupported:
        return False
    return _size(node) <= MAX_NODES


def function(node: syntax.Node, const: Callable[[Any, Any], Any]) -> Generated | None:
    """The generated function of `node`'s value, or None when the expression has parts
    outside the pure subset (or is too large). It raises GiveUp (or any exception) where
    the usual evaluation must take over; `const(it, node)` gives a built-in constant."""
    if _size(node) > MAX_NODES:
        return None
    w = _Writer()
    try:
        result = w.node(node, {})
    except _Unsupported:
        return None
    prologue = ["def generated(it):", "    scopes = it.scopes", "    used = it.used.add"]
    if w.names:
        prologue.append("    deprecated = it.deprecated")
        prologue.append("    if deprecated and not NAMES.isdisjoint(deprecated):")
        prologue.append("        give_up()")
    if w.uses_constants:
        prologue.append("    if it.fn_bindings:")  # inside a function, x y z are its own
        prologue.append("        give_up()")
    prologue.append("    state = it.state")
    source = "\n".join([*prologue, *w.lines, f"    return {result}"])
    scope: dict[str, Any] = {
        **w.consts,
        "NAMES": frozenset(w.names),
        "give_up": _give_up,
        "MacroValue": MacroValue,
        "Vec": Vec,
        "vec": Vec.of_floats,
        "truth": builtins.truth,
        "binary": builtins.binary,
        "unary": builtins.unary,
        "member": builtins.member,
        "fast": builtins.FLOAT_OPS,
        "index": _index,
        "const": const,
    }
    exec(compile(source, "<expression>", "exec"), scope)
    return scope["generated"]
