"""The shape of ``training/``: rooms (run <- evaluate <- sweep, studies) whose modules each import
on their own and one way, with no import circles (imports inside functions count too), imports
inside functions only for optional dependencies, no module over 800 lines, no private name
imported from another module, and nothing at the top but the command and the rooms."""

from __future__ import annotations

import ast
import importlib
import pkgutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import training

ROOT = Path(training.__file__).parent
ROOMS = ("run", "evaluate", "sweep", "studies")
MODULES = sorted(m.name for m in pkgutil.walk_packages([str(ROOT)], prefix="training."))


def _path(module: str) -> Path:
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin is not None, module
    return Path(spec.origin)


#: importable names of the optional dependencies (the extras [train], [sweep], [video]) and of
#: packages that are not dependencies at all: the only ones a function may import, so that the
#: module imports without them
OPTIONAL = (
    "torch",
    "stable_baselines3",
    "sb3_contrib",
    "tensorboard",
    "rich",
    "tqdm",
    "yaml",
    "matplotlib",
    "PIL",
    "imageio",
    "imageio_ffmpeg",
    "moviepy",
    "ray",
    "elastica",
)
#: modules whose contents other work streams own; their function-level imports are theirs to hoist
NOT_OURS = ("training.studies.calibrate", "training.studies.bench_physics")


@dataclass(frozen=True)
class Import:
    target: str  # the imported module (relative imports resolved)
    names: tuple[str, ...]  # the names of ``from target import ...``
    in_function: bool  # inside a function body (runs when called, not at import)
    guarded: bool  # inside ``try: ... except ImportError`` (an optional dependency's guard)


def _guards_import_error(node: ast.Try) -> bool:
    return any(
        h.type is not None
        and ("ImportError" in ast.unparse(h.type) or "ModuleNotFoundError" in ast.unparse(h.type))
        for h in node.handlers
    )


def _imports(module: str) -> list[Import]:
    """Every import statement of ``module``, at any depth."""
    path = _path(module)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out: list[Import] = []

    def visit(node: ast.AST, in_function: bool, guarded: bool) -> None:
        if isinstance(node, ast.Import):
            out.extend(Import(a.name, (), in_function, guarded) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            out.append(Import(base, tuple(a.name for a in node.names), in_function, guarded))
        in_function = in_function or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        if isinstance(node, ast.Try) and _guards_import_error(node):
            for child in node.body:
                visit(child, in_function, True)
            for part in (node.handlers, node.orelse, node.finalbody):
                for child in part:
                    visit(child, in_function, guarded)
            return
        for child in ast.iter_child_nodes(node):
            visit(child, in_function, guarded)

    visit(ast.parse(path.read_text(encoding="utf-8")), False, False)
    return out


def _graph() -> dict[str, set[str]]:
    """module -> the training modules its imports execute, module- and function-level alike
    (importing ``a.b.c`` runs the packages ``a`` and ``a.b`` first)."""
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for m in MODULES:
        for imp in _imports(m):
            submodules = [f"{imp.target}.{n}" for n in imp.names if f"{imp.target}.{n}" in graph]
            for target in submodules or [imp.target]:
                parts = target.split(".")
                for k in range(1, len(parts) + 1):
                    executed = ".".join(parts[:k])
                    if executed in graph and executed != m and not m.startswith(executed + "."):
                        graph[m].add(executed)
    return graph


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), and self-imports."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def connect(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                connect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph[v]:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            connect(v)
    return found


@pytest.mark.slow
def test_every_module_imports_first_in_a_fresh_interpreter():
    code = (
        "import subprocess, sys\n"
        "bad = []\n"
        f"for m in {MODULES!r}:\n"
        "    r = subprocess.run([sys.executable, '-c', 'import ' + m], capture_output=True,"
        " text=True)\n"
        "    if r.returncode: bad.append((m, r.stderr.strip().splitlines()[-1]))\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_no_import_circles():
    assert not _circles(_graph())


def test_the_circle_check_sees_function_level_imports():
    graph = {"a": {"b"}, "b": set()}
    assert _circles(graph) == []
    graph["b"].add("a")  # e.g. an import inside a function of b
    assert _circles(graph) == [["a", "b"]]
    assert any(i.in_function for i in _imports("training.run.logs"))  # matplotlib, in a function


def _room(module: str) -> str:
    return module.split(".")[1]


#: room -> the rooms it may import: run <- evaluate <- sweep, studies; the CLI imports by name
ROOM_IMPORTS = {
    "run": {"run"},
    "evaluate": {"run", "evaluate"},
    "sweep": {"run", "evaluate", "sweep"},
    "studies": {"run", "evaluate", "studies"},
    "cli": {"run"},
}


def test_rooms_import_one_way():
    offenders = []
    for m, targets in _graph().items():
        room = _room(m)
        if room not in ROOM_IMPORTS:
            continue
        offenders += [f"{m} imports {t}" for t in targets if _room(t) not in ROOM_IMPORTS[room]]
    assert not offenders, offenders


def test_functions_import_only_optional_dependencies():
    """An import inside a function hides a dependency (and circles); it is kept only for an
    optional dependency (or behind an ImportError guard), so the module imports without it."""
    offenders = []
    for m in MODULES:
        if m in NOT_OURS:
            continue
        for imp in _imports(m):
            top = imp.target.partition(".")[0]
            if imp.in_function and not imp.guarded and top not in OPTIONAL:
                offenders.append(f"{m} imports {imp.target} inside a function")
    assert not offenders, offenders


def test_no_module_over_800_lines():
    long = {}
    for m in MODULES:
        n = len(_path(m).read_text(encoding="utf-8").splitlines())
        if n > 800:
            long[m] = n
    assert not long, long


def test_no_private_name_is_imported_across_modules():
    offenders = []
    for m in MODULES:
        for imp in _imports(m):
            if imp.target.startswith("training"):
                offenders += [
                    f"{m} imports {imp.target}.{n}" for n in imp.names if n.startswith("_")
                ]
    assert not offenders, offenders


def test_the_top_of_the_package_is_the_command_and_the_rooms():
    top = {m.name for m in pkgutil.iter_modules([str(ROOT)])}
    assert top == {"cli", *ROOMS}, sorted(top)
