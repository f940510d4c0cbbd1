"""The layout's promises: every module imports on its own (no cycles), and the dependency runs
one way — model ← backends ← tasks ← envs ← training — with no Gymnasium/pybullet in the model."""

from __future__ import annotations

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import cdcr_gym

ROOT = Path(cdcr_gym.__file__).parent
MODULES = sorted(
    m.name
    for m in pkgutil.walk_packages([str(ROOT)], prefix="cdcr_gym.")
    if "bullet" not in m.name  # pybullet's own import is tested with the backend
)

#: package -> names its modules must not import (the layers above it, or simulators)
FORBIDDEN = {
    "model": (
        "gymnasium",
        "pybullet",
        "cdcr_gym.backends",
        "cdcr_gym.tasks",
        "cdcr_gym.envs",
        "cdcr_gym.controllers",
        "training",
        "torch",
    ),
    "backends": ("cdcr_gym.tasks", "cdcr_gym.envs", "cdcr_gym.controllers", "training", "torch"),
    "tasks": ("cdcr_gym.envs", "cdcr_gym.controllers", "training", "torch"),
    "envs": ("training", "torch", "stable_baselines3"),
}


@pytest.mark.slow  # ~17 s: one fresh interpreter per module
def test_every_module_imports_first_in_a_fresh_interpreter():
    code = (
        "import importlib, subprocess, sys\n"
        "bad = []\n"
        f"for m in {MODULES!r}:\n"
        "    r = subprocess.run([sys.executable, '-c', 'import ' + m], capture_output=True,"
        " text=True)\n"
        "    if r.returncode: bad.append((m, r.stderr.strip().splitlines()[-1]))\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_dependencies_run_one_way(package):
    offenders = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for name in _imports(path):
            if any(name == f or name.startswith(f + ".") for f in FORBIDDEN[package]):
                offenders.append(f"{path.relative_to(ROOT)} imports {name}")
    assert not offenders, offenders


def _absolute_imports(path: Path) -> set[str]:
    """Every module ``path`` imports, relative imports resolved against its package."""
    package = ("cdcr_gym",) + path.relative_to(ROOT).parent.parts
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = ".".join(package[: len(package) - node.level + 1]) if node.level else ""
            module = ".".join(p for p in (base, node.module or "") if p)
            names.add(module)
            names.update(f"{module}.{a.name}" for a in node.names)  # from pkg import submodule
    return names


@pytest.mark.parametrize(("backend", "other"), [("mujoco", "bullet"), ("bullet", "mujoco")])
def test_simulator_backends_stand_alone(backend, other):
    """The pybullet and MuJoCo backends import nothing from each other (what they share lives in
    ``cdcr_gym.model.discrete`` and ``cdcr_gym.backends.base``)."""
    files = sorted((ROOT / "backends" / backend).rglob("*.py"))
    assert files, backend
    forbidden = f"cdcr_gym.backends.{other}"
    offenders = [
        f"{path.relative_to(ROOT)} imports {name}"
        for path in files
        for name in _absolute_imports(path)
        if name == forbidden or name.startswith(forbidden + ".")
    ]
    assert not offenders, offenders
