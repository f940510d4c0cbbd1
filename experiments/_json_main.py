"""The command line of an experiment that computes one JSON report: ``--out`` and ``--quick``.

Shared by ``experiments.damping_check`` and ``experiments.dynamics_check``.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["json_main"]


def json_main(
    prog: str,
    doc: str,
    default_out: str,
    quick_help: str,
    run: Callable[..., dict[str, Any]],
    argv: list[str] | None = None,
) -> None:
    """Parse ``argv`` (``--out PATH``, default ``default_out``; ``--quick``, described by
    ``quick_help``), call ``run(quick=...)`` and write its result to ``--out`` as indented
    JSON (parent folders created); print ``wrote PATH``. ``prog`` is the ``python -m`` command,
    the first line of ``doc`` the help's description."""
    parser = argparse.ArgumentParser(prog=prog, description=doc.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path(default_out))
    parser.add_argument("--quick", action="store_true", help=quick_help)
    args = parser.parse_args(argv)
    out = run(quick=args.quick)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    print("wrote", args.out)
