"""The interpreter: syntax tree → IR.

Two phases per block body. *Expand* walks the elements, runs directives in place (`#if`
picks a branch, `#while`/`#for` loop, `#declare` binds, `#include` splices a file, a macro
call splices what its body yields) and evaluates expressions and nested blocks to values.
*Group* then reads the expanded stream with the block's schema (lang.eval.grouping). A
builder per block (lang.eval.builders) turns the groups into a value. Errors become
Diagnostics at the element's span and evaluation goes on. The interpreter owns the state:
scopes, macros, includes, file handles, the scene being built, and `to_ir`, which resolves
an object value into its IR. It implements the build context (lang.eval.context) the
builders see."""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from lang import (
    builtins,
    ir,
    lexical,
    paths,
    read_access,
    scene_store,
    schema,
    syntax,
)
from lang.builtins import EvalError, as_float
from lang.diagnostics import Diagnostic, DiagnosticSink, SceneError, Severity, Span, in_order
from lang.eval import (
    call_sites,
    cuts,
    data_shapes,
    expressions,
    fileio,
    follow_on,
    functions,
    grouping,
    loop_watch,
    macro_args,
    semicolons,
    splines,
    streamed,
    surfaces,
    textures,
    unknown,
    versioning,
)
from lang.eval.budget import RENDER, Budget, Exceeded, Meter
from lang.eval.builders import BUILDERS
from lang.eval.camera import CameraError
from lang.eval.coincident import coincident_faces
from lang.eval.edits import Edits
from lang.eval.elements import (
    LIST_KINDS,
    El,
    Grouped,
    Quiet,
    Statement,
)
from lang.eval.reach import lights_in_reach, objects_in_reach
from lang.eval.resolve import ObjectResolver
from lang.eval.scene import settings_at_top
from lang.ir_ops import (
    collect_lights,
    pattern_defaults_in,
    with_pattern_defaults,
)
from lang.keywords import ALL_WORDS
from lang.queries import QueriesFactory, SceneQueries
from lang.read_access import UNRESTRICTED, ReadAccess
from lang.values import (
    ArrayValue,
    CameraValue,
    ColorValue,
    FileHandle,
    FunctionValue,
    ListValue,
    MacroValue,
    ObjectPattern,
    ObjectValue,
    UnsupportedValue,
    describe,
    kind_of,
)

# Bounds that turn runaway scenes into diagnostics instead of hangs.
MAX_LOOP_ITERATIONS = 1_000_000
MAX_MACRO_DEPTH = 200
MAX_INCLUDE_DEPTH = 64
RECURSION_LIMIT = 30_000
# What a look-up of a file name on disk costs of the budget, in steps: about a millisecond
# (a stat and a realpath per folder searched), fifty statements' worth. A font looked up by
# each text object of a runaway loop, at one step each, kept `check` for a minute.
FIND_STEPS = 50


@dataclass
class Result:
    scene: ir.Scene | None  # None only when errors made a scene impossible
    diagnostics: list[Diagnostic]
    symbols: dict[str, object]  # global identifiers at the end (#declare'd values)
    files: list[str]  # every file read


class _Break(Exception):
    """`#break`: leaves the innermost #while, #for, #switch or macro, keeping what it had
    expanded before the #break (POV-Ray has already read those tokens)."""

    def __init__(self) -> None:
        super().__init__()
        self.partial: list[El] = []


class _Els(list):
    """A block's expanded elements; `failed` when one of them could not be evaluated (its
    error is reported), so the block's "missing value" complaints would only repeat it."""

    failed = False


# What a block says when one of its values is missing: after a value failed to evaluate
# (reported already), these only echo that error and are left out.
_CASCADE_CODES = frozenset({"E0211", "E0212"})


class _Halt(Exception):
    """`#error`: POV-Ray stops parsing."""


class _Scope(dict):
    """One symbol table; `kind` is global, include, macro or function."""

    def __init__(self, kind: str):
        super().__init__()
        self.kind = kind


# What a #declare may give straight to eval(): expressions that are no directive or macro
# call (a non-built-in call may be a macro's, whose elements eval_value gathers).
_VALUE_KINDS = frozenset(
    {syntax.Number, syntax.String, syntax.Ident, syntax.Const, syntax.Vector, syntax.Unary}
    | {syntax.Binary, syntax.Ternary, syntax.Member, syntax.Index, syntax.ColorCtor}
)
# bound once: eval() is the evaluator's hottest call
_EXPRESSIONS = expressions.EXPRESSIONS
# the node kinds lang.eval.expressions compiles into closures on first evaluation
_COMPILED_KINDS = frozenset(
    {syntax.Binary, syntax.Unary, syntax.Call, syntax.Vector, syntax.Member, syntax.Index}
    | {syntax.Ternary}
)


class Interpreter:
    def __init__(
        self,
        library_paths: Sequence[str] = (),
        *,
        clock: float = 0.0,
        allow_file_io: bool = True,
        image_width: int = 0,
        image_height: int = 0,
        debug_to_stderr: bool = False,
        animation: Mapping[str, float] | None = None,
        queries: QueriesFactory | None = None,
        declares: Mapping[str, float] | None = None,
        budget: Budget = RENDER,
        reads: ReadAccess = UNRESTRICTED,
        confine_reads: str | None = None,
        stores: bool = True,
    ):
        self.sink = DiagnosticSink()
        # which files may be read (lang.read_access); confine_reads names who reads only the
        # scene's folder and the library folders (check, the editor); stores: parses may be
        # kept between runs (lang.parse_store: off for tools that must write nothing)
        self.reads = reads
        self.confine_reads = confine_reads
        self.stores = stores
        self.meter = Meter(budget)  # the evaluation's total work (lang.eval.budget)
        self._queries_factory = queries
        self._queries: SceneQueries | None = None
        # functions called from the scene, with the scene's pattern defaults (the original
        # kept beside its copy, so its id stays unique)
        self._defaulted: dict[tuple[int, tuple[Any, ...]], tuple[ir.Function, ir.Function]] = {}
        # an object's IR for trace()/inside(), made once (the queries cache by object)
        self._query_objects: dict[int, tuple[ObjectValue, ir.Object]] = {}
        # frame_number, initial_frame, final_frame, initial_clock, final_clock, clock_delta,
        # clock_on of an animation (see animation_values); absent ones are POV-Ray's 0
        self.animation = dict(animation or {})
        self.library_paths = [str(p) for p in library_paths]
        self.clock = clock
        self.allow_file_io = allow_file_io
        self.image_width = image_width
        self.image_height = image_height
        self.debug_to_stderr = debug_to_stderr
        self.scopes: list[_Scope] = [_Scope("global")]
        # POV-Ray's Declare=Name=Value options: global floats before the first line is read
        self.scopes[0].update({name: float(v) for name, v in (declares or {}).items()})
        self.file_stack: list[str] = []
        self.files: list[str] = []
        self.parse_cache: dict[str, syntax.SourceFile] = {}
        # Syntax errors inside an included file's macros, reported when the macro is called
        # (as POV-Ray does): keyed by the macro's span.
        self.broken_macros: dict[Span, list[Diagnostic]] = {}
        # `#declare deprecated [once] "message" NAME`: NAME → [message, once, warned yet]
        self.deprecated: dict[str, list] = {}
        self.macro_depth = 0
        self.exhausted = False  # the budget ran out: the evaluation stops
        self.cut_braces = False  # a brace paired across directives was read (lang.eval.cuts)
        self.break_targets = 0  # the #while, #for, #switch and macros a #break may leave
        self.loose_depth = 0
        self.blob_depth = 0  # inside a blob body, `sphere`/`cylinder` are components
        self.state = builtins.BuiltinState()
        self.unknown_hints: unknown.Hints = {}  # an unknown name's hint, found once
        self.fn_bindings: list[dict[str, float]] = []
        self.version = 3.7
        self.version_set = False
        self.version_late: Span | None = None  # the first #version, if tokens came before
        self.first_statement: Span | None = None  # where the main file's first token is
        self.main_file = ""
        self.warned: set[str] = set()
        # Names the main file #declares (first place) and every name ever read, for the
        # "declared but never used" warning.
        self.main_declares: dict[str, Span] = {}
        self.used: set[str] = set()
        # scene state
        self.camera: ir.Camera | None = None
        self.lights: list[ir.Light] = []
        self.objects: list[ir.Object] = []
        self.settings: dict[str, Any] = {}
        self.background: ir.Color = ir.BLACK
        self.sky_sphere: tuple[ir.Pigment, ...] | None = None
        self.fog: ir.Fog | None = None
        self.fogs: list[ir.Fog] = []  # every fog block, in order (POV-Ray applies them all)
        self.rainbows: list[ir.Rainbow] = []
        self.media: list[ir.Media] = []  # atmospheric media blocks
        self.default_texture = ir.Texture()
        self.edits = Edits()  # blocks that modify what they are written into
        self._resolver = ObjectResolver()
        self.handles: dict[str, FileHandle] = {}
        # What the result depends on beyond the text of its files and its options (file
        # I/O, `now`, an image …): a result that does is not stored (lang.scene_store).
        self.outside: list[str] = []
        # every path an #include probed: the digest of the text read there, None for a miss
        self.probed: dict[str, str | None] = {}
        self._digests: dict[str, str] = {}  # resolved include path -> digest of its text
        # (name, the file naming it) -> what _find found, until the scene writes a file
        self._found: dict[tuple[str, str], tuple[str, str] | None] = {}
        self.printed: list[str] = []  # `#debug` text written to stderr
        # expressions compiled on first evaluation (lang.eval.expressions.compiled), by node
        self._compiled: dict[int, expressions.Compiled] = {}
        self._compiled_nodes: list[syntax.Node] = []
        self._evaluated: set[int] = set()  # ids of the nodes of those kinds evaluated once
        # Macros whose body is read as tokens (lang/eval/streamed.py): a statement that calls
        # one is read as tokens too, so that the macro's text joins the caller's.
        self.token_macros: set[str] = set()
        self._called: dict[int, tuple[syntax.Node, frozenset[str]]] = {}
        self._watches: dict[int, tuple[syntax.While, list[str] | None]] = {}
        self._texts: dict[str, str] = {}  # file -> its text, comments blanked out
        self._raw_texts: dict[str, str] = {}  # texts given, not read from a file
        # the tree walk's own expand_node (translate watches every node through its own)
        self._plain = type(self).expand_node is Interpreter.expand_node

    # ------------------------------------------------------------ running
    def run(self, text: str, filename: str) -> Result:
        # Scenes recurse through macros (trees, fractals) and nest blocks; each level costs a
        # few dozen Python frames, so give the interpreter room (MAX_MACRO_DEPTH still bounds
        # it), and the passes over the finished scene too (a union nested a thousand deep
        # was read, then the coincidence check ran out of frames: an internal error).
        old_limit = sys.getrecursionlimit()
        sys.setrecursionlimit(max(old_limit, RECURSION_LIMIT))
        try:
            return self._run(text, filename)
        finally:
            sys.setrecursionlimit(old_limit)

    def _run(self, text: str, filename: str) -> Result:
        self.main_file = filename
        if self.confine_reads is not None:
            self.reads = read_access.confined(
                Path(filename).resolve().parent, self.library_paths, self.confine_reads
            )
        self.state.readable = self.reads.allows
        self._raw_texts[filename] = text  # blanked only if a statement is read as tokens
        self.state.folder = str(Path(filename).resolve().parent)
        self.files.append(filename)
        tree, diags = self._parse_stored(text, filename)
        self.sink.items.extend(diags)
        if tree.body:
            self.first_statement = tree.body[0].span
        self.file_stack.append(filename)
        try:
            els = self.expand(tree.body, None, top=True)
            if self.cut_braces:
                els = cuts.report_loose(self, els, "the scene")
            for el in settings_at_top(self, els):
                self._top_level(el)
        finally:
            self.file_stack.pop()
        for h in list(self.handles.values()):
            fileio.flush(self, h)
        if not self.objects and not self.lights and not versioning.is_include(filename):
            # POV-Ray's Parse: a light source counts as an object there
            lines = max(1, len(text.splitlines()))
            self.sink.warning("W0304", "No objects in scene.", Span(filename, lines, 1, lines, 1))
        for name, span in self.main_declares.items():
            if name not in self.used:
                self.sink.warning(
                    "W0400",
                    f"`{name}` is declared but never used",
                    span,
                    "remove the declaration, or use the name",
                )
        if not self.exhausted:
            state = versioning.VersionState(
                self.version,
                self.version_set,
                self.version_late,
                self.first_statement,
                self.settings.get("assumed_gamma") is not None,
            )
            versioning.warn_at_end(self.sink, state, filename)
        scene = self._scene()
        try:
            self._warn_coincident(scene)
        except RecursionError:
            pass  # objects nested deeper than the frames allow: the warning is left out
        symbols = {k: v for k, v in self.scopes[0].items()}
        said = follow_on.drop(self.sink.unique(), diags, tree)
        return Result(scene, in_order(said), symbols, list(self.files))

    def parse_source(self, text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]]:
        """The syntax tree of one file's text. An extension point: the language server parses
        its open document incrementally, translate parses the text it is rewriting."""
        from lang.parser import parse  # lark is loaded on first use, not at import

        return parse(text, filename)

    def _parse_stored(self, text: str, filename: str) -> tuple[syntax.SourceFile, list[Diagnostic]]:
        """A file's parse, from `lang.parse_store` when it holds it. Subclasses that parse
        in their own way (the language server, translate) keep theirs; text without a file
        name is parsed."""
        if (
            type(self).parse_source is not Interpreter.parse_source
            or filename.startswith("<")
            or not self.stores
        ):
            return self.parse_source(text, filename)
        from lang import parse_store

        got = parse_store.load(text, filename)
        if got is None:
            got = self.parse_source(text, filename)
            parse_store.save(text, filename, *got)
        return got

    def _scene(self) -> ir.Scene:
        s = self.settings
        settings = ir.Settings(
            assumed_gamma=s.get("assumed_gamma"),
            version=self.version if self.version_set else None,
            max_trace_level=s.get("max_trace_level", 5),
            adc_bailout=s.get("adc_bailout", 1.0 / 255.0),
            ambient_light=s.get("ambient_light", (1.0, 1.0, 1.0)),
            radiosity=s.get("radiosity"),
            charset=s.get("charset", "ascii"),
        )
        scene = ir.Scene(
            camera=self.camera if self.camera is not None else ir.Camera(),
            lights=lights_in_reach(self, self.lights),
            objects=objects_in_reach(self, self.objects),
            settings=settings,
            background=self.background,
            sky_sphere=self.sky_sphere,
            fog=self.fog,
            fogs=tuple(self.fogs),
            rainbows=tuple(self.rainbows),
            media=tuple(self.media),
            files=tuple(self.files),
        )
        defaults = self._pattern_defaults()
        return with_pattern_defaults(scene, defaults) if defaults else scene

    def _warn_coincident(self, scene: ir.Scene) -> None:
        """Boxes whose faces coincide in different textures: POV-Ray's pick between the two
        varies from pixel to pixel, strala's does not (lang.eval.coincident)."""
        pairs, stopped = coincident_faces(scene.objects, scene.camera.location)
        if not pairs:
            return
        first, second, axis, coord = pairs[0]
        span = first.span or second.span
        if span is None:
            return
        plus = "+" if stopped else ""  # the search stopped before the end
        more = f" (and {len(pairs) - 1}{plus} more pairs)" if len(pairs) > 1 else ""
        self.sink.warning(
            "W0315",
            f"this box's face and the box's at {second.span or 'another place'} lie in one"
            f" plane ({axis} = {coord:g}) in different textures{more}: POV-Ray shows either"
            " texture from pixel to pixel there, strala always the first one",
            span,
        )

    def _pattern_defaults(self) -> dict[str, int]:
        """The scene-wide values POV-Ray's patterns read at render time, where they differ
        from the runtime's own defaults: the noise generator (global_settings', else 1
        for a scene of a language version before 3.5, as Parse_Frame sets it) and the
        number of wave sources."""
        s = self.settings
        version = self.version if self.version_set else 3.7
        gen = s.get("noise_generator") or (1 if version < 3.5 else 2)
        out = {"noise_generator": gen} if gen != 2 else {}
        if s.get("number_of_waves", 10) != 10:
            out["number_of_waves"] = s["number_of_waves"]
        return out

    # ------------------------------------------------------------ diagnostics
    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> SceneError:
        return SceneError(Diagnostic(Severity.ERROR, code, message, span, hint))

    def warn_once(
        self, key: str, message: str, span: Span, hint: str | None = None, code: str = "W0300"
    ) -> None:
        if key in self.warned:
            return
        self.warned.add(key)
        self.sink.warning(code, message, span, hint)

    def ignored(self, block: str, keyword: str, args: list[Any], span: Span) -> None:
        """Warn once per keyword that strala accepts but ignores (schema.IGNORED_ITEMS); an
        explicit 0 or `off` asks for nothing and is not warned about."""
        reason = schema.ignored_reason(block, keyword)
        if reason is None:
            return
        given = [a for a in args if a is not None]
        if given and all(isinstance(a, int | float) and not a for a in given):
            return
        self.warn_once(
            f"ignored:{reason}",  # one warning per missing feature (focal blur's four words)
            f"`{keyword}` is accepted but ignored",
            span,
            reason,
            code="W0308",
        )

    def unsupported(self, feature: str, span: Span, what: str = "") -> None:
        self.warn_once(
            f"unsupported:{feature}",
            f"`{feature}` is not supported yet{what}",
            span,
            "strala parses it and renders the rest of the scene",
        )

    # ------------------------------------------------------------ scopes
    def lookup(self, name: str) -> tuple[bool, Any]:
        for scope in reversed(self.scopes):
            if name in scope:
                self.used.add(name)
                return True, scope[name]
        return False, None

    def scope_of(self, name: str) -> _Scope | None:
        for scope in reversed(self.scopes):
            if name in scope:
                return scope
        return None

    def declare(self, name: str, value: Any, local: bool) -> None:
        """POV-Ray: #local binds in the innermost table; #declare updates the most local
        visible binding (so a macro can assign its by-reference parameters), else global."""
        if type(value) is not float:  # a float is never a recorded block (lang.eval.edits)
            self.edits.forget(value)
        scopes = self.scopes
        if local:
            scopes[-1][name] = value
            return
        for scope in reversed(scopes):
            if name in scope:
                scope[name] = value
                return
        scopes[0][name] = value

    def unknown_ident(self, name: str, span: Span) -> SceneError:
        found = unknown.hint(
            name, self.scopes, self.unknown_hints, self._folder(), self.library_paths
        )
        return self.error("E0201", f"unknown identifier `{name}`", span, found)

    # ------------------------------------------------------------ top level
    def _top_level(self, el: El) -> None:
        if el.kind == "comma":
            return
        if el.kind == "kw":
            self.sink.error(
                "E0210",
                f"`{el.value}` cannot stand at the top level",
                el.span,
                self.where_keyword(el.value),
            )
            return
        if el.kind == "entry":
            self.sink.error("E0212", "a `[ … ]` map entry outside a map", el.span)
            return
        v = el.value
        if v is None:
            return
        if isinstance(v, ObjectValue):
            self.objects.append(self.to_ir(v, placed=el.placed_default))
            self.lights.extend(collect_lights(v))
        elif isinstance(v, ir.Light):
            self.lights.append(v)
        elif isinstance(v, CameraValue):
            self.camera = v.camera
        elif isinstance(v, Statement):
            if v.kind == "background":
                self.background = v.value
            elif v.kind == "sky_sphere":
                self.sky_sphere = v.value
            elif v.kind == "fog":
                if self.fog is None:
                    self.fog = v.value
                self.fogs.append(v.value)
            elif v.kind == "rainbow":
                self.rainbows.append(v.value)
        elif isinstance(v, ir.Media):
            self.media.append(v)
        elif isinstance(v, UnsupportedValue):
            self.unsupported(v.keyword, el.span)
        else:
            self.sink.error(
                "E0212",
                f"{describe(v)} cannot stand alone at the top level",
                el.span,
                "only objects, lights, camera and settings make a scene; "
                "use #declare to name a value",
            )

    def where_keyword(self, name: str) -> str | None:
        homes = [b.name for b in schema.BLOCKS.values() if name in b.items]
        if homes:
            return f"`{name}` belongs inside " + ", ".join(f"`{h}`" for h in homes[:4])
        return None

    # ------------------------------------------------------------ expansion
    def expand(
        self, body: Sequence[syntax.Node], spec: schema.BlockSpec | None, top: bool = False
    ) -> list[El]:
        """Run directives, evaluate values; `top` keeps what came before an #error."""
        out: list[El] = _Els()
        opens: list[int] = []  # cut blocks open in this sequence (lang.eval.cuts)
        i, n = 0, len(body)
        while i < n:
            node = body[i]
            i += 1
            try:
                self.meter.step()
                if (
                    type(node) is syntax.Declare
                    and type(node.value) in _VALUE_KINDS
                    and node.semicolon
                    and self._plain
                    and not self.token_macros
                    and not opens
                ):
                    # the commonest statement of loops and macros, without the dispatch
                    # (what _d_declare does for an expression; nothing joins `out`)
                    self.assign(node, self.eval(node.value))
                    continue
                if (
                    isinstance(node, syntax.Declare)
                    and isinstance(node.value, syntax.Block)
                    and node.value.keyword == "texture"
                    and not node.indices
                ):
                    # `#declare T = texture {…} texture {…}`: POV-Ray's layered texture.
                    layers = []
                    while (
                        i < n
                        and isinstance(layer := body[i], syntax.Block)
                        and layer.keyword == "texture"
                    ):
                        layers.append(body[i])
                        i += 1
                    if layers:
                        stack = [self.eval(node.value), *(self.eval(b) for b in layers)]
                        self.declare(node.name, textures.layered(stack), node.local)
                        continue
                start = len(out)
                if type(node) is syntax.Tokens or (self.token_macros and self.token_call(node)):
                    # read as tokens from here on, to the next statement of the tree
                    i = streamed.read(self, body, i - 1, out, spec)
                else:
                    self.expand_node(node, out, cuts.spec_for(out, opens, spec) if opens else spec)
                if self.cut_braces:
                    cuts.pair(self, out, start, opens)
                if len(out) > start:
                    self._stamp_default(out, start)
            except SceneError as e:
                self.sink.items.append(e.diagnostic)
                out.failed = True  # type: ignore[attr-defined]
            except EvalError as e:
                self.sink.error("E0203", e.message, node.span, e.hint)
                out.failed = True  # type: ignore[attr-defined]
            except RecursionError:
                self.sink.error("E0231", "recursion too deep", node.span)
            except Quiet:
                pass
            except _Halt:
                if top:
                    return out
                raise
            except Exceeded as e:
                if not self.exhausted:  # said once, at the statement that went past it
                    self.exhausted = True
                    self.sink.error("E0238", e.message, node.span, e.hint)
                if top:
                    return out
                raise
            except _Break as e:
                e.partial[:0] = out  # this body's elements come before the inner ones
                raise
            except Exception as e:  # a bug in strala: still a diagnostic, never a traceback
                if isinstance(e, OverflowError) or (isinstance(e, ValueError) and "NaN" in str(e)):
                    # an infinite or NaN number (1e400, 0 * 1e400) where an integer goes
                    self.sink.error(
                        "E0203",
                        "a number here is infinite or not a number",
                        node.span,
                        "a count or an index must be a finite number",
                    )
                    out.failed = True  # type: ignore[attr-defined]
                    continue
                self.sink.error(
                    "E0200",
                    f"internal error while evaluating this: {type(e).__name__}: {e}",
                    node.span,
                    "please report this as a strala bug",
                )
        return out

    def _stamp_default(self, out: list[El], start: int) -> None:
        """Objects among out[start:] not stamped yet get the #default texture in effect now:
        POV-Ray gives an untextured object the default current where the object statement
        stands in the scene (its Post_Process), not where the object was declared, and an
        include or loop that places objects may change the default in between."""
        for k in range(start, len(out)):
            el = out[k]
            if el.placed_default is None and isinstance(el.value, ObjectValue):
                el.placed_default = self.default_texture

    def expand_node(self, node: syntax.Node, out: list[El], spec: schema.BlockSpec | None) -> None:
        """Expand one node into `out`. An extension point: translate watches which of its
        files' nodes are being evaluated when an error is reported."""
        t = type(node)
        n: Any = node  # dispatched on its exact type, which mypy cannot follow
        directive = _DIRECTIVES.get(t)
        if directive is not None:  # no other branch takes a directive
            directive(self, n, out, spec)
        elif t is syntax.Keyword:
            out.append(El("kw", n.name, n.span))
        elif t is syntax.Comma:
            out.append(El("comma", None, n.span))
        elif t is syntax.Expanded:
            out.extend(n.els)
        elif t is syntax.CutOpen:
            self.cut_braces = True
            out.append(cuts.open_element(n))
        elif t is syntax.CutClose:
            self.cut_braces = True
            out.append(El(cuts.CLOSE, None, n.span))
        elif t is syntax.MapEntry:
            out.append(El("entry", self.expand(n.body, None), n.span))
        elif t is syntax.Call and not n.builtin and self._is_macro(n.name):
            out.extend(self.call_macro(n))
        elif t is syntax.Ident and spec is not None and n.name in spec.soft:
            # strala's soft words are keywords inside the blocks that list them (and plain
            # names everywhere else), as lang/keywords.py documents
            out.append(El("kw", n.name, n.span))
        elif t is syntax.Ident and self._word_slot(out, spec) and not self.lookup(n.name)[0]:
            # an unknown word where an item takes a word (`scheme sqrt3`): the item's own
            # check names the choices, which says more than "unknown identifier"
            out.append(El("kw", n.name, n.span))
        elif t is syntax.Block and n.keyword == "default" and not n.params:
            # `default { … }` without the `#`: POV-Ray's older spelling of #default
            self._d_default(syntax.Default(n.span, n.body), out, spec)
        elif t is syntax.Block and n.keyword == "object" and schema.takes_object_pattern(spec):
            # `pigment { object { OBJ A, B } }`: the object pattern, not an object
            out.append(El("kw", "object", n.keyword_span or n.span))
            out.append(El("val", self._object_pattern(n), n.span))
        else:
            out.append(El("val", self.eval(n), n.span))

    def _object_pattern(self, node: syntax.Block) -> ObjectPattern:
        """`object { OBJECT item_outside, item_inside }` inside a pigment, normal or texture:
        the object (a declared one or a shape block) and up to two list items."""
        els = [e for e in self.expand(node.body, None) if e.kind != "comma"]
        span = node.keyword_span or node.span
        if not els or els[0].kind != "val" or not isinstance(els[0].value, ObjectValue):
            raise self.error(
                "E0211",
                "the object pattern needs an object first",
                els[0].span if els else span,
                "object { MyObject color rgb 0, color rgb 1 }",
            )
        items = []
        for e in els[1:]:
            if e.kind != "val" or kind_of(e.value) not in LIST_KINDS:
                what = f"`{e.value}`" if e.kind == "kw" else describe(e.value)
                raise self.error(
                    "E0211",
                    f"an object pattern lists colours, pigments, normals or textures, not {what}",
                    e.span,
                )
            items.append(e.value)
        if len(items) > 2:
            raise self.error("E0211", "an object pattern has two list items", els[3].span)
        return ObjectPattern(self.to_ir(els[0].value), tuple(items))

    @staticmethod
    def _word_slot(out: list[El], spec: schema.BlockSpec | None) -> bool:
        if spec is None or not out or out[-1].kind != "kw":
            return False
        item = spec.items.get(out[-1].value)
        return item is not None and item.args[:1] == ("word",)

    def token_call(self, node: syntax.Node) -> bool:
        """Whether `node` calls a macro whose body is read as tokens."""
        held = self._called.get(id(node))
        if held is None or held[0] is not node:
            names = frozenset(
                n.name for n in syntax.walk(node) if type(n) is syntax.Call and not n.builtin
            )
            held = self._called[id(node)] = (node, names)
        for name in held[1] & self.token_macros:
            found, v = self.lookup(name)
            if found and isinstance(v, MacroValue) and v.read_as_tokens:
                return True
        return False

    def source_text(self, file: str) -> str:
        """A file's text with its comments blanked out (positions as its syntax tree's)."""
        text = self._texts.get(file)
        if text is None:
            raw = self._raw_texts.get(file)
            if raw is None:
                raw = Path(file).read_text(encoding="utf-8", errors="replace")
            text = self._texts[file] = lexical.strip_comments(raw, file, DiagnosticSink())
        return text

    def _is_macro(self, name: str) -> bool:
        found, v = self.lookup(name)
        return found and isinstance(v, MacroValue)

    # ------------------------------------------------------------ directives
    def _d_include(self, node: syntax.Include, out: list[El], spec) -> None:
        name = self.eval(node.path)
        if not isinstance(name, str):
            raise self.error("E0202", "#include needs a file name string", node.span)
        found = self._find(name)
        if found is None:
            where = paths.searched(self._folder(), self.library_paths, self._scene_folder())
            raise self.error(
                "E0220", f"include file `{name}` not found", node.span, f"searched {where}"
            )
        probed_at, path = found
        if not self.reads.allows(path):
            # `#include "/etc/passwd"` printed its lines in the diagnostics
            who = self.confine_reads or self.reads.why
            raise self.error(
                "E0261",
                f"`{name}` is outside the folders that may be read ({who})",
                node.span,
                "keep included files in the scene's folder or a library folder (-L)",
            )
        if path in self.file_stack:
            raise self.error(
                "E0221",
                f"include cycle: `{name}` is already being included",
                node.span,
                " → ".join(Path(f).name for f in [*self.file_stack, path]),
            )
        if len(self.file_stack) > MAX_INCLUDE_DEPTH:
            raise self.error("E0221", "includes nested too deeply", node.span)
        tree = self.parse_cache.get(path)
        if tree is None:
            try:
                text = Path(path).read_text(encoding="utf-8", errors="replace")
            except OSError as e:
                raise self.error(
                    "E0220", f"cannot read `{name}`: {e.strerror}", node.span
                ) from None
            tree, diags = self._parse_stored(text, path)
            self.sink.items.extend(self._defer_macro_errors(tree.body, diags))
            self.parse_cache[path] = tree
            self._digests[path] = scene_store.digest(text)
        self.probed[probed_at] = self._digests.get(path)
        if path not in self.files:
            self.files.append(path)
        self.file_stack.append(path)
        self.scopes.append(_Scope("include"))
        try:
            out.extend(self.expand(tree.body, spec))
        finally:
            self.scopes.pop()
            self.file_stack.pop()

    def _defer_macro_errors(
        self, body: Sequence[syntax.Node], diags: list[Diagnostic]
    ) -> list[Diagnostic]:
        """An include file's syntax errors inside a macro's body wait for a call of the macro:
        POV-Ray's own files have macros that only its textual parser reads (`#write` of half
        a mesh in one #if branch), and a scene that never calls them must not fail."""
        macros: list[syntax.MacroDef] = []
        stack = list(body)
        while stack:
            n = stack.pop()
            if isinstance(n, syntax.MacroDef):
                macros.append(n)
            elif isinstance(n, syntax.If):
                stack.extend(x for _, b in n.branches for x in b)
            elif isinstance(n, syntax.IfDef):
                stack.extend(n.then + (n.other or []))
        kept = []
        for d in diags:
            home = next((m for m in macros if m.span.holds_line_of(d.span)), None)
            if home is None or d.severity is not Severity.ERROR:
                kept.append(d)
            else:
                self.broken_macros.setdefault(home.span, []).append(d)
        return kept

    def resolve(self, name: str) -> str | None:
        """The file `name` names (not an include's: see _find). Looking for it, found or
        not, makes the result depend on a file whose text is not followed."""
        self.depends_outside(f"the file {name}")
        found = self._find(name)
        if found is None or not self.reads.allows(found[1]):
            return None  # a file outside the folders that may be read is not there
        return found[1]

    def _find(self, name: str) -> tuple[str, str] | None:
        """(the path probed, the resolved path) of the file `name` names: in the current
        file's folder, the library paths, the stdlib (lang.paths). The misses are kept in
        `probed` (lang.scene_store follows them). Each name is looked for once per file
        naming it (a font named by every text object of a loop), until a file is written."""
        key = (name, self.file_stack[-1] if self.file_stack else "")
        if key in self._found:
            return self._found[key]
        self.meter.step(FIND_STEPS)
        try:
            found = paths.find(
                name, self._folder(), self.library_paths, self.probed, self._scene_folder()
            )
        except OSError:  # a name the system cannot look up (too long): not found
            found = None
        got = self._found[key] = None if found is None else (found.probed, found.path)
        return got

    def wrote(self, path: str) -> None:
        """The scene wrote the file `path`: a name looked for before may be found now."""
        self._found.clear()

    def read_data(self, path: str) -> None:
        """The scene read the data file `path` (#fopen): it is among the files read (a
        render elsewhere needs it: runtime.bundle)."""
        if path not in self.files:
            self.files.append(path)

    def _folder(self) -> Path:
        """The folder of the file being read, where its includes are looked for first."""
        return Path(self.file_stack[-1]).resolve().parent if self.file_stack else Path.cwd()

    def _scene_folder(self) -> Path | None:
        """The main scene's folder, where includes are looked for next (lang.paths)."""
        return Path(self.main_file).resolve().parent if self.main_file else None

    def standalone(self, result: Result) -> bool:
        """The result depends only on its files' text and the options, and has no errors:
        it may be stored (lang.scene_store)."""
        return (
            result.scene is not None
            and not self.outside
            and not self.state.looked_outside
            and not any(d.severity is Severity.ERROR for d in result.diagnostics)
        )

    def depends_outside(self, why: str) -> None:
        """The result depends on `why`, something besides the files' text and the options."""
        if why not in self.outside:
            self.outside.append(why)

    def _d_declare(self, node: syntax.Declare, out: list[El], spec) -> None:
        if type(node.value) in _DIRECTIVES or type(node.value) is syntax.CutOpen:
            since = len(self.sink.items)
            els = self.expand([node.value], None)
            if els and els[-1].kind == cuts.OPEN:
                # `#declare U = union {` closed across a directive: declared once closed
                out.append(El(cuts.DECLARE, node, node.span))
                out.extend(els)
                return
            value = self.declared(els, node.span, since)
        else:
            value = self.eval_value(node.value)
            if not self.token_macros:  # a macro read as tokens may bring the `;` itself
                semicolons.check(self.sink, node, value, self.version, self.lookup)
        self.assign(node, value)

    def assign(self, node: syntax.Declare, value: Any) -> None:
        """Give a #declare's (or #local's) name, or its array element, the value."""
        if node.indices:
            found, arr = self.lookup(node.name)
            if not found or not isinstance(arr, ArrayValue):
                raise self.error(
                    "E0250", f"`{node.name}` is not an array", node.name_span or node.span
                )
            idx = tuple(
                expressions.array_index(self, arr, [self.eval(i) for i in node.indices], node.span)
            )
            arr.data[arr.flat_index(idx)] = value
            return
        if isinstance(value, ArrayValue) and isinstance(node.value, syntax.Ident):
            value = ArrayValue(value.dims, list(value.data))  # POV-Ray copies arrays
        name, scopes = node.name, self.scopes
        if node.local:
            if len(scopes) > 1 and name in scopes[0] and name not in scopes[-1]:
                self.sink.warning(
                    "W0401",
                    f"`#local {name}` hides the global `{name}` inside this macro",
                    node.name_span or node.span,
                    "rename one of them if the global was meant",
                )
        elif self.file_stack and self.file_stack[-1] == self.main_file:
            self.main_declares.setdefault(name, node.name_span or node.span)
        if node.deprecated is not None:
            self.deprecated[node.name] = [node.deprecated, node.deprecated_once, False]
        elif self.deprecated:
            self.deprecated.pop(node.name, None)
        self.declare(node.name, value, node.local)

    def eval_value(self, node: syntax.Node) -> Any:
        """A declared value: an expression, or a directive that yields one value."""
        if type(node) in _DIRECTIVES or (
            isinstance(node, syntax.Call) and not node.builtin and self._is_macro(node.name)
        ):
            since = len(self.sink.items)
            els = self.expand([node], None)
            return self.declared(els, node.span, since)
        return self.eval(node)

    def declared(self, els: list[El], span: Span, since: int) -> Any:
        """The one value a #declare takes from a macro or directive; textures one after
        another (a macro giving `texture {…} texture {…}`) make POV-Ray's layered texture."""
        vals = [e for e in els if e.kind != "comma"]
        if len(vals) > 1 and all(e.kind == "val" and isinstance(e.value, ir.Texture) for e in vals):
            return textures.layered([e.value for e in vals])
        return self.single(els, span, "this declaration", since)

    def single(self, els: list[El], span: Span, what: str, since: int | None = None) -> Any:
        vals = [e for e in els if e.kind != "comma"]
        if len(vals) == 1 and vals[0].kind == "val":
            return vals[0].value
        if since is not None and any(d.severity is Severity.ERROR for d in self.sink.items[since:]):
            raise Quiet()  # the cause is already reported; do not add a cascade
        if not vals:
            raise self.error("E0202", f"{what} yields no value", span)
        raise self.error(
            "E0202",
            f"{what} yields {len(vals)} elements where one value is needed",
            span,
            "macros are functions: an expression takes exactly one value from them",
        )

    def _d_undef(self, node: syntax.Undef, out, spec) -> None:
        scope = self.scope_of(node.name)
        if scope is not None:
            del scope[node.name]
        else:
            self.sink.warning(
                "W0312",
                "Attempt to undef unknown identifier",
                node.span,
                f"POV-Ray ignores the `#undef` the same way; `{node.name}` is not declared here",
            )

    def _d_if(self, node: syntax.If, out, spec) -> None:
        for cond, body in node.branches:
            if cond is None:
                out.extend(self.expand(body, spec))
                return
            c = self.eval(cond)
            if c != 0.0 if type(c) is float else builtins.truth(c):
                out.extend(self.expand(body, spec))
                return

    def _d_ifdef(self, node: syntax.IfDef, out, spec) -> None:
        if self.is_defined(node) != node.negate:
            out.extend(self.expand(node.then, spec))
        elif node.other is not None:
            out.extend(self.expand(node.other, spec))

    def is_defined(self, node: syntax.IfDef) -> bool:
        """Whether #ifdef's name (or array element) is defined."""
        found, v = self.lookup(node.name)
        if found and node.indices and isinstance(v, ArrayValue):
            try:
                idx = tuple(
                    expressions.array_index(
                        self, v, [self.eval(i) for i in node.indices], node.span
                    )
                )
                found = v.data[v.flat_index(idx)] is not None
            except SceneError:
                found = False
        return found

    def _d_switch(self, node: syntax.Switch, out, spec) -> None:
        value = as_float(self.eval(node.value), "#switch value")
        running = False
        self.break_targets += 1
        try:
            for case in node.cases:
                if not running:
                    if case.values is None:
                        running = True
                    elif case.is_range:
                        lo, hi = (as_float(self.eval(v), "#range bound") for v in case.values)
                        running = lo <= value <= hi
                    else:
                        c = as_float(self.eval(case.values[0]), "#case value")
                        running = abs(c - value) < builtins.EQUALITY_EPSILON
                if running:
                    out.extend(self.expand(case.body, spec))
                    if case.breaks:
                        return
        except _Break as e:
            out.extend(e.partial)
        finally:
            self.break_targets -= 1

    def _d_while(self, node: syntax.While, out, spec) -> None:
        n = 0
        held = self._watches.get(id(node))
        if held is None or held[0] is not node:
            # judged once per loop: the walk over its body costs more than a pass of it
            held = self._watches[id(node)] = (node, loop_watch.watched_names(node))
        watched = held[1]
        self.break_targets += 1
        try:
            cond, truth = node.cond, builtins.truth
            while True:
                c = self.eval(cond)
                if not (c != 0.0 if type(c) is float else truth(c)):
                    break
                n += 1
                self.meter.step()
                if n > MAX_LOOP_ITERATIONS:
                    raise self.error(
                        "E0230",
                        f"#while ran past {MAX_LOOP_ITERATIONS} iterations",
                        node.span,
                        "check that the loop's condition eventually becomes false",
                    )
                before = None if watched is None else [self.lookup(v) for v in watched]
                mark = len(self.sink.items)
                out.extend(self.expand(node.body, spec))
                if self._errors_since(mark):
                    break  # reported once: the next iterations would repeat it
                if (
                    before is not None
                    and watched is not None
                    and loop_watch.same_values(before, [self.lookup(v) for v in watched])
                ):
                    raise self.error(
                        "E0230",
                        "this #while never ends: nothing its condition reads changed in a pass",
                        node.span,
                        "change a variable of the condition in the body, or leave with #break",
                    )
        except _Break as e:
            out.extend(e.partial)
        finally:
            self.break_targets -= 1

    def _errors_since(self, mark: int) -> bool:
        items = self.sink.items
        return len(items) > mark and any(d.severity is Severity.ERROR for d in items[mark:])

    def _d_for(self, node: syntax.For, out, spec) -> None:
        start = as_float(self.eval(node.start), "#for start")
        end = as_float(self.eval(node.end), "#for end")
        step = as_float(self.eval(node.step), "#for step") if node.step is not None else 1.0
        if step == 0.0:
            raise self.error("E0230", "#for step is zero", node.span)
        count = (end - start) / step + 1
        if count > MAX_LOOP_ITERATIONS:  # said at once, not after a million passes
            raise self.error(
                "E0230",
                f"#for would run {count:.4g} times, more than {MAX_LOOP_ITERATIONS}",
                node.span,
                "check the loop's bounds and step",
            )
        i, n = start, 0
        self.break_targets += 1
        try:
            while (i <= end + 1e-10) if step > 0 else (i >= end - 1e-10):
                n += 1
                self.meter.step()
                if n > MAX_LOOP_ITERATIONS:
                    raise self.error(
                        "E0230", f"#for ran past {MAX_LOOP_ITERATIONS} iterations", node.span
                    )
                (self.scope_of(node.var) or self.scopes[-1])[node.var] = i
                mark = len(self.sink.items)
                out.extend(self.expand(node.body, spec))
                if self._errors_since(mark):
                    break  # reported once: the next iterations would repeat it
                found, cur = self.lookup(node.var)
                i = (as_float(cur) if found else i) + step
        except _Break as e:
            out.extend(e.partial)
        finally:
            self.break_targets -= 1

    def _d_macro(self, node: syntax.MacroDef, out, spec) -> None:
        if len(node.body) == 1 and type(node.body[0]) is syntax.Tokens:
            self.token_macros.add(node.name)
        self.scopes[0][node.name] = MacroValue(
            node.name,
            tuple(node.params),
            tuple(node.body),
            self.file_stack[-1],
            node.span,
            optional=frozenset(node.optional),
        )

    def _d_version(self, node: syntax.Version, out, spec) -> None:
        # POV-Ray 3.7 (tokenize.cpp, VERSION_TOKEN): any #version, in the scene or an include,
        # marks the language version as set; the one the scene ends with decides the gamma and
        # legacy rules. Its includes set 3.5 and restore it: `#include "colors.inc"` makes 3.7.
        first = self.first_statement
        if not self.version_set and (first is None or node.span[:3] != first[:3]):
            self.version_late = node.span  # POV-Ray's languageVersionLate: tokens came first
        self.version = as_float(self.eval(node.value), "#version")
        self.version_set = True
        semicolons.check_version(self.sink, node, self.version)

    def _d_message(self, node: syntax.Message, out, spec) -> None:
        v = self.eval(node.value)
        text = v if isinstance(v, str) else str(v)
        if node.kind in ("render", "statistics"):
            self.sink.warning(
                "W0312",
                "#render and #statistics streams are no longer available."
                " Redirecting output to #debug stream.",
                node.span,
                "POV-Ray writes the text as `#debug` does; write `#debug`",
            )
        if node.kind in ("debug", "render", "statistics"):
            if self.debug_to_stderr:
                sys.stderr.write(text)
                self.printed.append(text)
            self.sink.note("N0100", text.rstrip("\n"), node.span)
        elif node.kind == "warning":
            self.sink.warning("W0301", text.rstrip("\n"), node.span)
        elif node.kind == "error":
            self.sink.error("E0240", text.rstrip("\n"), node.span, "raised by #error")
            raise _Halt()

    def _d_default(self, node: syntax.Default, out, spec) -> None:
        for el in self.expand(node.body, None):
            v = el.value
            t = self.default_texture
            if isinstance(v, ir.Texture):
                self.default_texture = v
            elif isinstance(v, ir.Pigment):
                self.default_texture = replace(t, pigment=self.edits.onto(self, v, t.pigment))
            elif isinstance(v, ir.Finish):
                self.default_texture = replace(t, finish=self.edits.onto(self, v, t.finish))
            elif isinstance(v, ir.Normal):
                self.default_texture = replace(t, normal=self.edits.onto(self, v, t.normal))
            elif el.kind != "comma":
                self.sink.error(
                    "E0212",
                    "#default takes texture, pigment, finish or normal blocks",
                    el.span,
                )

    def _d_break(self, node: syntax.Break, out, spec) -> None:
        if not self.break_targets:
            raise self.error(
                "E0234", "`#break` outside a #while, #for, #switch or macro", node.span
            )  # POV-Ray: "Invalid context for #break", and it stops
        raise _Break()

    # ---- file I/O (inside the scene's folder only, and never while checking)
    def _d_fileop(self, node: syntax.FileOp, out, spec) -> None:
        fileio.file_op(self, node)

    def undeclare(self, name: str) -> None:
        """Remove the innermost binding of `name`, if any."""
        scope = self.scope_of(name)
        if scope is not None:
            del scope[name]

    # ------------------------------------------------------------ macros
    def call_macro(self, node: syntax.Call) -> list[El]:
        macro, scope, refs = self.enter_macro(node)
        since = len(self.sink.items)
        try:
            els = self.expand(macro.body, None)
        except _Break as e:  # POV-Ray: #break in a macro ends the macro
            els = _Els(e.partial)
        except SceneError as e:
            e.diagnostic = call_sites.through(e.diagnostic, macro, node.span)
            raise
        finally:
            self.leave_macro(scope, refs)
            call_sites.mark(self.sink.items, since, macro, node.span)
        return els

    def enter_macro(self, node: syntax.Call) -> tuple[MacroValue, _Scope, dict]:
        """Check a macro call's arguments, evaluate them and enter the macro's scope;
        returns the macro, its scope and its by-reference parameters (for leave_macro)."""
        _, macro = self.lookup(node.name)
        required = len([p for p in macro.params if p not in macro.optional])
        if len(node.args) < required:
            args = macro_args.split_object_args(self, node.args, len(macro.params))
            if len(args) != len(node.args):
                node = syntax.Call(node.span, node.name, args, node.builtin)
        if len(node.args) > len(macro.params):
            raise self.error(
                "E0232",
                f"macro `{macro.name}` takes {len(macro.params)} argument(s), got {len(node.args)}",
                node.span,
                f"#macro {macro.name}({', '.join(macro.params)})",
            )
        missing = [p for p in macro.params[len(node.args) :] if p not in macro.optional]
        if missing:
            raise self.error(
                "E0232",
                f"macro `{macro.name}` takes {len(macro.params)} argument(s), got "
                f"{len(node.args)}: `{missing[0]}` is missing",
                node.span,
                f"#macro {macro.name}({', '.join(macro.params)})",
            )
        self.meter.step()
        if self.macro_depth >= MAX_MACRO_DEPTH:
            raise self.error("E0231", f"macro `{macro.name}` recursed too deeply", node.span)
        if self.broken_macros and macro.span is not None and macro.span in self.broken_macros:
            self.sink.items.extend(self.broken_macros[macro.span])
            self.broken_macros[macro.span] = []  # its own errors are shown once
            where = f"{Path(macro.file).name}:{macro.span.line}"
            raise self.error(
                "E0233",
                f"macro `{macro.name}` ({where}) does not parse",
                node.span,
                "its syntax errors are listed with it",
            )
        args = [self.eval_value(a) for a in node.args]
        scope = _Scope("macro")
        refs: dict[str, tuple[_Scope, str, Any]] = {}
        for name, node_arg, value in zip(macro.params, node.args, args, strict=False):
            scope[name] = value
            if isinstance(node_arg, syntax.Ident):
                owner = self.scope_of(node_arg.name)
                if owner is not None:
                    refs[name] = (owner, node_arg.name, value)
        self.scopes.append(scope)
        self.file_stack.append(macro.file)
        self.macro_depth += 1
        self.break_targets += 1
        return macro, scope, refs

    def leave_macro(self, scope: _Scope, refs: dict) -> None:
        self.break_targets -= 1
        self.macro_depth -= 1
        self.file_stack.pop()
        self.scopes.pop()
        # By-reference parameters: an assignment to a parameter reaches the caller's name.
        for name, (owner, target, old) in refs.items():
            if name in scope and scope[name] is not old:
                owner[target] = scope[name]

    def call_function(self, fn: FunctionValue, args: list[Any], span: Span) -> float | ColorValue:
        if len(args) != len(fn.params):
            raise self.error(
                "E0232", f"this function takes {len(fn.params)} argument(s), got {len(args)}", span
            )
        values = tuple(as_float(a, "function argument") for a in args)
        compiled = fn.compiled
        if compiled is None:
            return 0.0
        if compiled.kind == "pigment" and isinstance(compiled.body, ir.FnPigment):
            # POV-Ray: a pigment function called from the scene gives the colour
            queries = self.scene_queries("a pigment function's value")
            if queries is None:
                self._without_renderer("a pigment function", span)
                return ColorValue.of(0.0, 0.0, 0.0)
            pigment = self._with_scene_defaults(compiled).body.pigment
            x, y, z = (values + (0.0, 0.0, 0.0))[:3]
            rgbft = queries.pigment(pigment, (x, y, z))
            return ColorValue((rgbft[0], rgbft[1], rgbft[2], rgbft[3], rgbft[4]))
        try:
            return functions.call(compiled, values)
        except functions.Unevaluable as e:
            queries = self.scene_queries(f"{e.what}'s value")
            if queries is None:
                self._without_renderer(e.what, span)
                return 0.0
            return queries.function(self._with_scene_defaults(compiled), values)

    def _without_renderer(self, what: str, span: Span) -> None:
        self.warn_once(
            f"no-renderer:{what}",
            f"{what} called from the scene language gives 0 here",
            span,
            "its value needs the renderer's patterns: `strala render` computes it",
        )

    def _with_scene_defaults(self, fn: ir.Function) -> ir.Function:
        """fn's patterns with the scene-wide settings so far (noise_generator…), as the
        render will see them; made once per function and settings."""
        defaults = self._pattern_defaults()
        key = (id(fn), tuple(sorted(defaults.items())))
        hit = self._defaulted.get(key)
        if hit is None:
            hit = self._defaulted[key] = (fn, pattern_defaults_in(fn, defaults))
        return hit[1]

    # ------------------------------------------------------------ expressions
    def eval(self, node: syntax.Node) -> Any:
        if type(node) is syntax.Number:  # the commonest node there is
            return node.value
        if type(node) in _COMPILED_KINDS:
            # compiled when evaluated again (a loop's, a macro's): compiling what runs once
            # would cost more than it saves
            key = id(node)
            hit = self._compiled.get(key)
            if hit is not None:
                return hit(self)
            if key not in self._evaluated:
                self._evaluated.add(key)
            else:
                # kept beside its node, whose id then stays its own for the evaluation; a
                # node without a closure of its own keeps the tree walk (asked once)
                fn = self._compiled[key] = expressions.compiled(node) or expressions.walker(node)
                self._compiled_nodes.append(node)
                return fn(self)
        try:
            return _EXPRESSIONS[type(node)](self, node)
        except KeyError:
            if type(node) in _DIRECTIVES:
                return self.eval_value(node)
            raise self.error("E0202", "this is not a value", node.span) from None
        except EvalError as e:
            raise self.error("E0203", e.message, node.span, e.hint) from None

    def scene_queries(self, why: str = "trace() or inside()") -> SceneQueries | None:
        self.depends_outside(why)
        if self._queries is None and self._queries_factory is not None:
            self._queries = self._queries_factory()
        return self._queries

    def query_object(self, obj: ObjectValue) -> ir.Object:
        key = id(obj)
        if key not in self._query_objects:
            # obj kept: its id stays unique
            self._query_objects[key] = (
                obj,
                pattern_defaults_in(self.to_ir(obj), self._pattern_defaults()),
            )
        return self._query_objects[key][1]

    # ------------------------------------------------------------ blocks
    def eval_block(self, node: syntax.Block) -> Any:
        kw = node.keyword
        span = node.keyword_span or node.span
        if kw not in ALL_WORDS:
            raise follow_on.misspelt_block(self, kw, span)
        if kw == "function":
            return functions.build(self, node)
        if kw in schema.LIST_BLOCKS:
            els = [e for e in self.expand(node.body, None) if e.kind != "comma"]
            items = [e.value for e in els]
            spans = [e.span for e in els]
            count = None
            if kw not in schema.UNCOUNTED_LISTS and items and isinstance(items[0], float):
                count = int(items[0])
                items, spans = items[1:], spans[1:]
            if count is not None and count != len(items) and kw != "face_indices":
                self.sink.warning(
                    "W0302",
                    f"`{kw}` declares {count} item(s) but lists {len(items)}",
                    span,
                )
            return ListValue(kw, tuple(items), count, node.span, item_spans=tuple(spans))
        if kw == "spline":
            return splines.build_spline(self, node)
        if kw == "bicubic_patch":
            return surfaces.bicubic_patch(self, node)
        if self.blob_depth and kw in ("sphere", "cylinder"):
            self.blob_depth, depth = 0, self.blob_depth  # nested blocks are ordinary again
            try:
                return data_shapes.component(self, node)
            finally:
                self.blob_depth = depth
        if kw in schema.DATA_SHAPES:
            return data_shapes.build(self, node)
        if kw in schema.UNSUPPORTED_SHAPES:
            self.unsupported(kw, span)
            return surfaces.unsupported_object(self, node)
        spec = schema.BLOCKS.get(kw)
        if spec is None:
            self.loose_depth += 1
            try:
                self.expand(node.body, None)
            finally:
                self.loose_depth -= 1
            return UnsupportedValue(kw, span)
        els = self.expand(node.body, spec)
        if self.cut_braces and cuts.has_loose(els):
            els = _Els(cuts.report_loose(self, els, f"this `{kw}` block"))
            els.failed = True
        if getattr(els, "failed", False):
            return self._build_after_failure(spec, els, node)
        g = grouping.group(self, spec, els, node)
        try:
            return self.build(kw, g, node)
        except EvalError as e:
            raise self.error("E0203", e.message, span, e.hint) from None
        except CameraError as e:
            raise self.error("E0270", str(e), span) from None

    def build(self, keyword: str, g: Grouped, node: syntax.Block) -> Any:
        """The value of block `keyword` from its grouped items (lang.eval.builders)."""
        return BUILDERS[keyword](self, g, node)

    def _build_after_failure(self, spec: schema.BlockSpec, els: list[El], node: syntax.Block):
        """Build a block one of whose values failed (and was reported): its complaints about a
        missing or extra value would repeat that error, so they are dropped, and a block that
        cannot be built without the value is dropped quietly."""
        mark = len(self.sink.items)
        try:
            g = grouping.group(self, spec, els, node)
        except SceneError as e:
            if e.diagnostic.code in _CASCADE_CODES:
                raise Quiet() from None
            raise
        finally:
            self.sink.items[mark:] = [
                d for d in self.sink.items[mark:] if d.code not in _CASCADE_CODES
            ]
        try:
            return self.build(node.keyword, g, node)
        except SceneError as e:
            if e.diagnostic.code in _CASCADE_CODES:
                raise Quiet() from None
            raise
        except EvalError as e:
            raise self.error("E0203", e.message, node.keyword_span or node.span, e.hint) from None
        except CameraError as e:
            raise self.error("E0270", str(e), node.keyword_span or node.span) from None

    # ------------------------------------------------------------ objects
    def to_ir(
        self,
        obj: ObjectValue,
        parent: ir.Matrix = ir.IDENTITY,
        inherited: ir.Texture | None = None,
        placed: ir.Texture | None = None,
    ) -> ir.Object:
        """The object resolved into the IR (lang.eval.resolve), with the current #default."""
        return self._resolver.to_ir(obj, self.default_texture, parent, inherited, placed=placed)


_DIRECTIVES: dict[type, Callable[..., None]] = {
    syntax.Include: Interpreter._d_include,
    syntax.Declare: Interpreter._d_declare,
    syntax.Undef: Interpreter._d_undef,
    syntax.If: Interpreter._d_if,
    syntax.IfDef: Interpreter._d_ifdef,
    syntax.Switch: Interpreter._d_switch,
    syntax.While: Interpreter._d_while,
    syntax.For: Interpreter._d_for,
    syntax.MacroDef: Interpreter._d_macro,
    syntax.Version: Interpreter._d_version,
    syntax.Message: Interpreter._d_message,
    syntax.Default: Interpreter._d_default,
    syntax.FileOp: Interpreter._d_fileop,
    syntax.Break: Interpreter._d_break,
}
