"""Documented defaults match the code (docstrings must not drift from signatures)."""

from __future__ import annotations

import ast
import inspect
import re

import pytest

from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.envs.env import CDCREnv
from cdcr_gym.envs.factory import make_env
from cdcr_gym.tasks.reach import Reach


def _literal(text: str):
    text = text.strip().strip("`")
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text  # a bare word such as tension_delta


def test_env_arguments_table_matches_the_signature():
    doc = inspect.getdoc(CDCREnv)
    rows = re.findall(r"^\| ``(\w+)``\s*\|\s*([^|]+?)\s*\|", doc, flags=re.MULTILINE)
    params = inspect.signature(CDCREnv.__init__).parameters
    documented = {name: default for name, default in rows if name in params}
    assert set(documented) == set(params) - {"self"}, "every argument has a row, and only those"
    for name, default in documented.items():
        if default == "(required)":
            assert params[name].default is inspect.Parameter.empty
        elif name == "task":
            assert params[name].default is None  # None means Reach()
        else:
            assert _literal(default) == params[name].default, name


def test_env_observation_table_is_the_spec_table_of_the_paper_reach_env():
    env = make_env("CCKA", "Reach")
    table = env.observation_spec.table()
    assert table in inspect.getdoc(CDCREnv)


def test_reach_task_documents_its_arguments():
    doc = inspect.getdoc(Reach)
    for name in inspect.signature(Reach.__init__).parameters:
        if name != "self":
            assert f"{name}:" in doc, name


@pytest.mark.parametrize(
    "name",
    [
        "gravity",
        "links_per_span",
        "control_timestep",
        "physics_timestep",
        "tip_payload",
        "damping_ratio",
        "gui",
    ],
)
def test_bullet_backend_documented_defaults_match_the_signature(name):
    doc = inspect.getdoc(BulletBackend)
    entry = re.search(rf"^\s*{name}:(.*?)(?=^\s*\w+:|\Z)", doc, flags=re.MULTILINE | re.DOTALL)
    assert entry, f"{name} is documented"
    match = re.search(
        r"\(default\s+``?([^`),]+?)``?[ ,)]|\(default\s+([^),\s]+)", entry.group(1)
    ) or re.search(r"``(True|False)`` \(default\)", entry.group(1))
    assert match, f"{name}: no default stated"
    stated = next(g for g in match.groups() if g is not None)
    stated = re.sub(r"\s*s$", "", stated.strip())  # drop a unit
    assert _literal(stated) == inspect.signature(BulletBackend.__init__).parameters[name].default


@pytest.mark.parametrize("owner", [CDCREnv, Reach])
def test_docstring_tables_have_no_continuation_rows(owner):
    """Markdown tables have no multi-line rows: a row with an empty first cell renders as a row
    of its own (the docs page showed such split rows)."""
    doc = inspect.getdoc(owner)
    rows = [line.strip() for line in doc.splitlines() if line.strip().startswith("|")]
    split = [row for row in rows if re.match(r"^\|\s+\|", row)]
    assert not split, split
