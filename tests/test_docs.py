"""Documented defaults match the code (docstrings must not drift from signatures)."""

from __future__ import annotations

import ast
import importlib.util
import inspect
import json
import re
from pathlib import Path

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


# --- the README and the docs site -------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: pages left out of the history check (none: every user page is checked)
_NOT_YET_CHECKED: set[str] = set()


def _user_pages() -> list[Path]:
    """The README and every docs page outside the experiments log."""
    pages = [ROOT / "README.md"]
    pages += [p for p in sorted(DOCS.glob("*.md")) if p.name not in _NOT_YET_CHECKED]
    return pages


def _install_block(page: Path) -> str:
    text = page.read_text(encoding="utf-8")
    match = re.search(r"<!-- install -->\n(.*?)<!-- /install -->", text, re.S)
    assert match, f"{page.name} has no install block"
    return match.group(1)


def test_install_text_is_the_same_everywhere():
    """One install text: the README, the home page and getting started carry the same block, and
    no other user page gives a different torch install line."""
    pages = [ROOT / "README.md", DOCS / "index.md", DOCS / "getting-started.md"]
    blocks = {page.name: _install_block(page) for page in pages}
    assert len(set(blocks.values())) == 1, "the install blocks differ"
    block = blocks["README.md"]
    assert "pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu" in block
    assert 'pip install -e ".[train,video]"' in block
    # a torch line anywhere else in the user pages is the block's or the two commands'
    allowed = {
        "pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu",
        "pip install torch==2.13.0",
    }
    for page in _user_pages():
        for line in re.findall(
            r"pip install torch[^\s`&]*(?:\s+--index-url\s+\S+)?", page.read_text()
        ):
            assert line.strip() in allowed, f"{page.name}: {line!r}"


def test_the_readme_keeps_the_two_commands_and_stays_short():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 300
    ci = 'pip install torch==2.13.0 && pip install -e ".[test]" && python -m pytest -m "not slow"'
    main = (
        'pip install torch==2.13.0 && pip install -e ".[train,video]" && cdcr-gym train '
        "configs/ppo_ccka_fast.yaml --run-dir runs/fast && cdcr-gym evaluate runs/fast"
    )
    assert ci in text.splitlines() and main in text.splitlines()


@pytest.mark.parametrize("page", _user_pages(), ids=lambda p: p.name)
def test_user_pages_carry_no_development_history(page):
    """Issue numbers, commit hashes and talk about one machine belong in docs/experiments/."""
    pattern = re.compile(
        r"issue [0-9]+|commit [0-9a-f]{7}|this VM|CI machine|SPEC §|shared/seed"
        r"|`(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}`",  # a bare commit hash in code quotes
        re.I,
    )
    hits = [line for line in page.read_text(encoding="utf-8").splitlines() if pattern.search(line)]
    assert not hits, hits


def test_readme_links_resolve():
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)\s]+)\)", text) + re.findall(r'src="([^"]+)"', text)
    local = [t.split("#")[0] for t in targets if not re.match(r"[a-z]+:", t) and t[0] != "#"]
    assert local, "the README links to its docs"
    missing = [t for t in local if not (ROOT / t).exists()]
    assert not missing, missing


def test_results_page_is_the_generator_output():
    """docs/results.md is written by docs/gen_results.py from the committed result JSONs
    (benchmark, dynamics, real-robot calibration), and names each one's numbers."""
    spec = importlib.util.spec_from_file_location("gen_results", DOCS / "gen_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    expected = module.render_page()
    page = (DOCS / "results.md").read_text(encoding="utf-8")
    assert page == expected, "docs/results.md is stale: run python docs/gen_results.py"
    report = json.loads((module.CALIBRATION / "report.json").read_text(encoding="utf-8"))
    assert f"{report['validation']['rmse_aligned_mm']:.2f} mm" in page
    assert "## Dynamics: bending frequencies" in page
    speed = json.loads(module.SPEED.read_text(encoding="utf-8"))
    assert "## Speed: single env and batched env" in page and speed["command"] in page


def test_every_docs_page_is_reachable():
    """Each page is in the mkdocs navigation or in the experiments log, which its index lists."""
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for page in DOCS.glob("*.md"):
        assert f" {page.name}" in nav, f"{page.name} is not in the navigation"
    index = (DOCS / "experiments" / "index.md").read_text(encoding="utf-8")
    for page in (DOCS / "experiments").glob("*.md"):
        if page.name != "index.md":
            assert f"]({page.name})" in index, f"experiments/{page.name} is not listed"


def _architecture_tree_paths(text: str) -> list[str]:
    """The paths of the tree in docs/architecture.md, rebuilt from its indentation: an entry is
    the first word of a line ending in ``/`` (a folder) or ``.py`` (a module); deeper lines are
    inside the last folder above them."""
    block = re.search(r"```text\n(.*?)```", text, re.S)
    assert block, "architecture.md has no tree"
    paths: list[str] = []
    stack: list[tuple[int, str]] = []  # (indent, folder path)
    for line in block.group(1).splitlines():
        match = re.match(r"( *)(\S+)", line)
        if (
            not match
            or len(match.group(1)) > 12
            or not re.fullmatch(r"[\w.]+(/|\.py)", match.group(2))
        ):
            continue  # a continuation line of a description (they start in column 21)
        indent, name = len(match.group(1)), match.group(2)
        while stack and stack[-1][0] >= indent:
            stack.pop()
        path = (stack[-1][1] if stack else "") + name
        paths.append(path)
        if name.endswith("/"):
            stack.append((indent, path))
    return paths


def test_architecture_names_only_paths_that_exist():
    """Every folder and module of the tree in docs/architecture.md, and every ``cdcr_gym/...``,
    ``training/...`` or ``experiments/...`` path named on the page, exists in the checkout."""
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    tree = _architecture_tree_paths(text)
    assert "cdcr_gym/model/discrete.py" in tree and "training/studies/" in tree, tree
    named = re.findall(r"\b((?:cdcr_gym|training|experiments)/[\w/]*\w(?:\.py|/)?)", text)
    missing = [p for p in tree + named if not (ROOT / p).exists()]
    assert not missing, missing
    # the "Where a change goes" list names modules relative to cdcr_gym/
    relative = re.findall(
        r"`((?:model|backends|tasks|envs|controllers|calibration)/\w+\.py)`", text
    )
    assert relative and not [p for p in relative if not (ROOT / "cdcr_gym" / p).exists()]
