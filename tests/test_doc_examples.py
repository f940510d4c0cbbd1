"""Every Python block of the README and the user-guide pages below runs on its own and shows its
result: a script block in a fresh interpreter (exit 0, something printed), a ``>>>`` block as a
doctest. A block that needs an earlier block's variables fails here."""

from __future__ import annotations

import doctest
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = ("README.md", "docs/getting-started.md", "docs/index.md", "docs/model.md")


def _python_blocks() -> list[tuple[str, str]]:
    blocks = []
    for page in PAGES:
        text = (ROOT / page).read_text(encoding="utf-8")
        for i, match in enumerate(re.finditer(r"^```python\n(.*?)^```", text, re.S | re.M)):
            blocks.append((f"{page}#{i + 1}", match.group(1)))
    return blocks


BLOCKS = _python_blocks()


def test_the_pages_have_python_blocks():
    assert len(BLOCKS) >= 5, [name for name, _ in BLOCKS]


@pytest.mark.parametrize("name,code", BLOCKS, ids=[name for name, _ in BLOCKS])
def test_block_runs_alone_and_shows_its_result(name, code, tmp_path):
    if code.lstrip().startswith(">>>"):
        parser = doctest.DocTestParser()
        test = parser.get_doctest(code, {}, name, name, 0)
        runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
        runner.run(test)
        assert runner.failures == 0 and runner.tries > 0, f"{name}: doctest failed"
        return
    result = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,  # nothing from the checkout's directory but the installed package
        capture_output=True,
        text=True,
        timeout=300,
        env={"MPLBACKEND": "Agg", "PATH": "", "PYTHONPATH": str(ROOT)},
    )
    assert result.returncode == 0, f"{name} failed:\n{result.stderr[-2000:]}"
    assert result.stdout.strip(), f"{name} printed nothing"
