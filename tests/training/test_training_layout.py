"""The shape of ``training/``: rooms (run, evaluate, sweep, studies) whose modules each import on
their own, with no import circles (counting imports inside functions too), no module over 800
lines and no private name imported from another module; the old flat paths stay as aliases."""

from __future__ import annotations

import ast
import importlib
import pkgutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import training
from training.deprecated import MOVED

ROOT = Path(training.__file__).parent
ROOMS = ("run", "evaluate", "sweep", "studies")
MODULES = sorted(
    m.name for m in pkgutil.walk_packages([str(ROOT)], prefix="training.") if m.name not in MOVED
)
#: the new modules: everything but the deprecated aliases (and their package)
NEW = [
    m for m in MODULES if m.split(".")[1] in ROOMS or m in ("training.cli", "training.deprecated")
]


def _path(module: str) -> Path:
    spec = importlib.util.find_spec(module)
    assert spec is not None and spec.origin is not None, module
    return Path(spec.origin)


def _imports(module: str) -> list[tuple[str, list[str]]]:
    """(imported module, names) of every import statement in ``module``, at any depth."""
    path = _path(module)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            out.append((base, [a.name for a in node.names]))
    return out


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in NEW}
    for m in NEW:
        for target, names in _imports(m):
            submodules = [f"{target}.{n}" for n in names if f"{target}.{n}" in graph]
            if submodules:  # `from training.evaluate import plots`: the module, not the package
                graph[m].update(submodules)
            elif target in graph and target != m:
                graph[m].add(target)
    return graph


@pytest.mark.slow
def test_every_new_module_imports_first_in_a_fresh_interpreter():
    code = (
        "import subprocess, sys\n"
        "bad = []\n"
        f"for m in {NEW!r}:\n"
        "    r = subprocess.run([sys.executable, '-c', 'import ' + m], capture_output=True,"
        " text=True)\n"
        "    if r.returncode: bad.append((m, r.stderr.strip().splitlines()[-1]))\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_no_import_circles():
    graph = _graph()
    cycles = []
    state: dict[str, int] = {}

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            # a package's __init__ that forwards names lazily is not a circle of its modules
            if nxt in stack[:-1] and nxt not in ("training.evaluate", "training.sweep"):
                cycles.append(stack[stack.index(nxt) :] + [nxt])
            elif state.get(nxt) is None:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for m in sorted(graph):
        if state.get(m) is None:
            visit(m, [m])
    assert not cycles, cycles


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
        for target, names in _imports(m):
            if target.startswith("training"):
                offenders += [f"{m} imports {target}.{n}" for n in names if n.startswith("_")]
    assert not offenders, offenders


@pytest.mark.parametrize("old", sorted(MOVED))
def test_every_old_module_path_is_an_alias_of_the_new_one(old):
    new, _ = MOVED[old]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert importlib.import_module(old) is importlib.import_module(new) or old.endswith(
            "training.reproduce"
        )


def test_the_old_python_m_forms_still_run_and_name_the_new_command():
    result = subprocess.run(
        [sys.executable, "-m", "training.ik_demo", "--episodes", "1"],
        capture_output=True,
        text=True,
        cwd=ROOT.parent,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    assert "cdcr-gym demo" in result.stderr
