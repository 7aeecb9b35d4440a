"""The build context: what the evaluator offers the code that turns syntax into values.

Expressions (lang.eval.expressions), block builders (scene, textures, surfaces, media,
data shapes, functions, splines) and the tools that watch an evaluation (the language
server, translate) see the interpreter through this interface and nothing else; the
interpreter (lang.eval.interpreter) implements it. A builder never imports the
interpreter, so the interpreter can import every builder."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from lang import builtins, ir, schema, syntax
    from lang.diagnostics import DiagnosticSink, SceneError, Span
    from lang.eval.budget import Meter
    from lang.eval.edits import Edits
    from lang.eval.elements import El, Grouped
    from lang.read_access import ReadAccess
    from lang.values import ColorValue, FileHandle, FunctionValue, ObjectValue


class BuildContext(Protocol):
    # diagnostics and the state a scene's evaluation carries
    sink: DiagnosticSink
    state: builtins.BuiltinState
    settings: dict[str, Any]
    default_texture: ir.Texture
    edits: Edits  # blocks that modify what they are written into (lang.eval.edits)
    deprecated: dict[str, list]
    animation: dict[str, float]
    fn_bindings: list[dict[str, float]]
    version: float
    clock: float
    image_width: int
    image_height: int
    main_file: str
    loose_depth: int  # > 0: inside a block whose items are read leniently (no errors)
    blob_depth: int  # > 0: inside a blob body, where sphere/cylinder are components
    handles: dict[str, FileHandle]  # the files #fopen opened, by their names
    allow_file_io: bool  # False while checking: #fopen does nothing
    reads: ReadAccess  # which files may be read, and written (lang.read_access)
    meter: Meter  # the evaluation's total work and memory (lang.eval.budget)

    def error(self, code: str, message: str, span: Span, hint: str | None = None) -> SceneError:
        """A SceneError to raise; reported once it reaches the element being expanded."""
        ...

    def warn_once(
        self, key: str, message: str, span: Span, hint: str | None = None, code: str = ...
    ) -> None:
        """A warning given once per `key` in an evaluation."""
        ...

    def ignored(self, block: str, keyword: str, args: list[Any], span: Span) -> None:
        """`keyword` is accepted in `block` and has no effect in strala."""
        ...

    def unsupported(self, feature: str, span: Span, what: str = "") -> None:
        """`feature` is POV-Ray's and not rendered yet: one warning per feature."""
        ...

    def unknown_ident(self, name: str, span: Span) -> SceneError: ...

    def where_keyword(self, name: str) -> str | None:
        """A hint naming the blocks where `name` is valid."""
        ...

    def resolve(self, name: str) -> str | None:
        """The resolved path of the data file `name` (an image, a font, a density file)."""
        ...

    def depends_outside(self, why: str) -> None: ...

    def wrote(self, path: str) -> None:
        """The scene wrote the file `path` (what was looked up may be found elsewhere now)."""
        ...

    def read_data(self, path: str) -> None:
        """The scene read the data file `path` (#fopen to read): among the files read."""
        ...

    # symbols
    def lookup(self, name: str) -> tuple[bool, Any]: ...

    def declare(self, name: str, value: Any, local: bool) -> None: ...

    def undeclare(self, name: str) -> None:
        """Remove the innermost binding of `name`, if any."""
        ...

    def assign(self, node: syntax.Declare, value: Any) -> None:
        """What `#declare` (or `#local`) does with its value once it has one."""
        ...

    # evaluation
    def eval(self, node: syntax.Node) -> Any: ...

    def eval_value(self, node: syntax.Node) -> Any:
        """The one value a node yields, directives included (`#declare X = #if …`)."""
        ...

    def eval_block(self, node: syntax.Block) -> Any: ...

    def build(self, keyword: str, g: Grouped, node: syntax.Block) -> Any:
        """The value of block `keyword` from its grouped items (the registered builder)."""
        ...

    def expand(
        self, body: list[syntax.Node], spec: schema.BlockSpec | None, top: bool = False
    ) -> list[El]: ...

    def single(self, els: list[El], span: Span, what: str, since: int | None = None) -> Any: ...

    def call_macro(self, node: syntax.Call) -> list[El]: ...

    def call_function(
        self, fn: FunctionValue, args: list[Any], span: Span
    ) -> float | ColorValue: ...

    def to_ir(
        self,
        obj: ObjectValue,
        parent: ir.Matrix = ...,
        inherited: ir.Texture | None = None,
        placed: ir.Texture | None = None,
    ) -> ir.Object: ...

    # trace() and inside()
    def scene_queries(self, why: str = ...) -> Any: ...

    def query_object(self, obj: ObjectValue) -> ir.Object: ...


# What turns one block's grouped items into its value (see lang.eval.builders).
Builder = Callable[[BuildContext, "Grouped", "syntax.Block"], Any]
