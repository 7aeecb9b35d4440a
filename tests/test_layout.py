"""The code's structure, held by tests: a module's `_private` names stay inside it, the
import graph has no circles but the one the language makes, no Python file outgrows a reader,
and every module says what it owns. The checks read the source as syntax trees; nothing of
the project is imported or run."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from conftest import ROOT

PACKAGES = ("lang", "runtime")
MAX_LINES = 1500

# The compiled extensions are private modules; each has one Python module that wraps it
# (loads it, falls back to numpy without it) and is the only one that imports it.
EXTENSION_WRAPPERS = {
    "runtime._whitted": "runtime/whitted.py",
    "runtime._boxtree": "runtime/trace.py",
    "runtime._pixels": "runtime/color.py",
}

# Names with a leading underscore that are public API of the standard library's types
# (named tuples) or of the interpreter (sys._getframe, os._exit).
PUBLIC_UNDERSCORED = frozenset(
    {"_replace", "_fields", "_asdict", "_make", "_field_defaults", "_exit", "_getframe"}
    # numpy's MT19937 seeded as C++'s std::mt19937 is (noise.py: POV-Ray's random streams)
    | {"_legacy_seeding"}
)

# The one import circle the language itself makes: `function { pigment { … } }` and
# `pigment { function { … } }` evaluate each other; the cycle is broken at run time by a
# documented lazy import.
ALLOWED_CIRCLES: list[frozenset[str]] = [
    frozenset({"runtime/functions.py", "runtime/patterns.py"}),
]


def _sources(*roots: str) -> Iterator[Path]:
    for root in roots:
        yield from sorted((ROOT / root).rglob("*.py"))


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def _module_name(rel: str) -> str:
    parts = rel.removesuffix(".py").split("/")
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


_PROJECT_MODULES = {_module_name(_rel(p)): _rel(p) for p in _sources(*PACKAGES)}


def _is_project(module: str) -> bool:
    return module.split(".")[0] in PACKAGES or module == "conftest"


def _absolute(rel: str, node: ast.ImportFrom) -> str:
    """The absolute module an import-from names (relative imports resolved against `rel`)."""
    if not node.level:
        return node.module or ""
    base = _module_name(rel).split(".")
    if not rel.endswith("__init__.py"):
        base = base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join([*base, *([node.module] if node.module else [])])


@dataclass
class _Defined:
    """Every name a module defines itself: its functions, classes, methods, assignment
    targets (also attributes: `x._cache = …`), parameters and keyword arguments."""

    names: set[str]

    @classmethod
    def of(cls, tree: ast.AST) -> _Defined:
        names: set[str] = set()
        for n in ast.walk(tree):
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(n.name)
            elif isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store):
                names.add(n.id)
            elif isinstance(n, ast.Attribute) and isinstance(n.ctx, ast.Store):
                names.add(n.attr)
            elif isinstance(n, ast.arg):
                names.add(n.arg)
            elif isinstance(n, ast.keyword) and n.arg:
                names.add(n.arg)
        return cls(names)


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__") and name not in PUBLIC_UNDERSCORED


def crossings(path: Path) -> Iterator[str]:
    """Each place where the module at `path` reaches another module's private name: imports
    one, reads one off an imported module, calls one on an object whose class lives
    elsewhere, or overrides one in a subclass of another module's class."""
    rel = _rel(path)
    tree = ast.parse(path.read_text(), rel)
    defined = _Defined.of(tree)
    modules: dict[str, str] = {}  # local name -> imported module
    foreign: set[str] = set()  # names imported from other project modules (classes, …)
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            for a in n.names:
                if _is_project(a.name):
                    modules[a.asname or a.name.split(".")[0]] = a.name
                else:
                    modules.setdefault(a.asname or a.name.split(".")[0], "")
        elif isinstance(n, ast.ImportFrom):
            source = _absolute(rel, n)
            for a in n.names:
                full = f"{source}.{a.name}"
                local = a.asname or a.name
                if not _is_project(source):
                    modules.setdefault(local, "")
                    continue
                if full in _PROJECT_MODULES:
                    modules[local] = full
                else:
                    foreign.add(local)
                if _private(a.name) and EXTENSION_WRAPPERS.get(full) != rel:
                    yield f"{rel}: imports {full}"
    for n in ast.walk(tree):
        if isinstance(n, ast.ClassDef) and any(
            isinstance(b, ast.Name) and b.id in foreign for b in n.bases
        ):
            for item in n.body:
                if isinstance(item, ast.FunctionDef) and _private(item.name):
                    yield f"{rel}: {n.name} overrides {item.name}"
        if not isinstance(n, ast.Attribute) or not _private(n.attr):
            continue
        owner = n.value
        if isinstance(owner, ast.Name) and owner.id in modules:
            if modules[owner.id] and f"{modules[owner.id]}.{n.attr}" not in EXTENSION_WRAPPERS:
                yield f"{rel}: {modules[owner.id]}.{n.attr}"
            continue
        if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
            continue
        if n.attr not in defined.names:
            yield f"{rel}: .{n.attr}"


def _import_edges(path: Path) -> set[str]:
    """The project files the module at `path` imports, wherever the import stands (lazy
    imports inside functions and TYPE_CHECKING imports count: they are still a dependency),
    including `importlib.import_module("…")` with a literal name."""
    rel = _rel(path)
    tree = ast.parse(path.read_text(), rel)
    out: set[str] = set()

    def add(module: str) -> None:
        if module in _PROJECT_MODULES:
            out.add(_PROJECT_MODULES[module])

    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            for a in n.names:
                add(a.name)
        elif isinstance(n, ast.ImportFrom):
            source = _absolute(rel, n)
            for a in n.names:
                full = f"{source}.{a.name}"
                add(full if full in _PROJECT_MODULES else source)
        elif (
            isinstance(n, ast.Call)
            and getattr(n.func, "attr", getattr(n.func, "id", None)) == "import_module"
            and n.args
            and isinstance(n.args[0], ast.Constant)
            and isinstance(n.args[0].value, str)
        ):
            name = n.args[0].value
            if name.startswith("."):
                package = _module_name(rel).rsplit(".", 1)[0]
                name = f"{package}{name}"
            add(name)
        elif (
            isinstance(n, ast.Call)
            and getattr(n.func, "attr", getattr(n.func, "id", None)) == "import_module"
            and n.args
            and isinstance(n.args[0], ast.JoinedStr)
            and isinstance(n.args[0].values[0], ast.Constant)
        ):  # import_module(f"pkg.{name}"): any module of the package
            prefix = str(n.args[0].values[0].value)
            out.update(f for m, f in _PROJECT_MODULES.items() if m.startswith(prefix))
    out.discard(rel)
    return out


def circles() -> list[frozenset[str]]:
    """The strongly connected components of the import graph with more than one file."""
    graph = {_rel(p): _import_edges(p) for p in _sources(*PACKAGES)}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []

    def visit(v: str) -> None:  # Tarjan's algorithm
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(frozenset(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_reaches_another_modules_private_names():
    found = sorted({c for p in _sources(*PACKAGES, "tests") for c in crossings(p)})
    assert not found, "private names used outside their module:\n" + "\n".join(found)


def test_import_graph_has_only_the_allowed_circle():
    new = [sorted(c) for c in set(circles()) - set(ALLOWED_CIRCLES)]
    assert not new, f"import circles: {new}"


def test_the_allowed_circle_is_a_documented_lazy_import():
    """Each file of the allowed circle imports the other only inside a function, where a
    comment says why."""
    for circle in ALLOWED_CIRCLES:
        for rel in circle:
            if circle - {rel} & _import_edges(ROOT / rel) == set():
                continue
            text = (ROOT / rel).read_text()
            tree = ast.parse(text)
            top = {
                _PROJECT_MODULES.get(_absolute(rel, n) if isinstance(n, ast.ImportFrom) else "")
                for n in tree.body
                if isinstance(n, ast.ImportFrom)
            } | {
                _PROJECT_MODULES.get(f"{_absolute(rel, n)}.{a.name}")
                for n in tree.body
                if isinstance(n, ast.ImportFrom)
                for a in n.names
            }
            assert not (circle - {rel}) & top, f"{rel} imports its circle at module level"


def test_no_python_file_is_too_long():
    long = [
        _rel(p) for p in _sources(*PACKAGES, "tests") if len(p.read_text().splitlines()) > MAX_LINES
    ]
    assert not long, f"over {MAX_LINES} lines: {long}"


def test_every_module_says_what_it_owns():
    bare = [_rel(p) for p in _sources(*PACKAGES) if not ast.get_docstring(ast.parse(p.read_text()))]
    assert not bare, f"modules without a docstring: {bare}"


def test_the_checks_see_a_crossing(tmp_path, monkeypatch):
    """The checker itself: each kind of crossing it claims to find is found."""
    import test_layout as me

    pkg = tmp_path / "lang"
    pkg.mkdir()
    (pkg / "__init__.py").write_text('"""x"""\n')
    (pkg / "a.py").write_text(
        '"""a"""\ndef _hidden(): pass\nclass Base:\n    def _hook(self): pass\n'
    )
    (pkg / "b.py").write_text(
        '"""b"""\nfrom lang.a import _hidden\nfrom lang import a\nfrom lang.a import Base\n'
        "a._hidden()\nclass Sub(Base):\n    def _hook(self): pass\n"
        "def f(it):\n    return it._secret()\n"
    )
    monkeypatch.setattr(me, "ROOT", tmp_path)
    monkeypatch.setattr(
        me,
        "_PROJECT_MODULES",
        {"lang": "lang/__init__.py", "lang.a": "lang/a.py", "lang.b": "lang/b.py"},
    )
    found = set(crossings(pkg / "b.py"))
    assert found == {
        "lang/b.py: imports lang.a._hidden",
        "lang/b.py: lang.a._hidden",
        "lang/b.py: Sub overrides _hook",
        "lang/b.py: ._secret",
    }
