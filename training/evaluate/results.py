"""Markdown tables of evaluated runs, straight from their ``run.json`` and ``eval*.json``.

Usage::

    python -m training.evaluate.results RUN_DIR[:EVAL_NAME] ... [--conditions straight_100steps,random_100steps]

``EVAL_NAME`` picks the evaluation file (``eval`` = ``eval.json``, the default;
``eval_BulletReach-v0`` = ``eval_BulletReach-v0.json``). One row per run and condition: the
training command's wall time and steps (from ``run.json``), the policy's final-error statistics
and the analytic-IK oracle's on the same goals (from the evaluation JSON).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from training.evaluate.conditions import canonical_condition, read_eval

__all__ = ["rows", "main"]

HEADER = (
    "| run | evaluated on | condition | train wall time | train steps | success ≤5 mm | ≤1 mm "
    "| mean | median | p95 | max | IK ≤5 mm | IK median | IK p95 | IK max "
    "| Δ cable length vs IK (median) |"
)


def _fmt(x: float) -> str:
    return f"{x:.3f}" if x < 10 else f"{x:.1f}"


def rows(run_dir: Path, eval_name: str = "eval", conditions: list[str] | None = None) -> list[str]:
    """Markdown table rows for one run's evaluation file."""
    meta: dict[str, Any] = json.loads((run_dir / "run.json").read_text())
    data: dict[str, Any] = read_eval(run_dir / f"{eval_name}.json")
    wall = meta.get("total_wall_time_s")
    wall_s = f"{wall / 60:.1f} min" if wall is not None else "?"
    out = []
    for name, c in data["conditions"].items():
        if conditions and name not in {canonical_condition(c) for c in conditions}:
            continue
        e, ik = c["error_mm"], c["ik"]
        env = data["env_id"].split("/")[-1]
        overrides = {
            k: v
            for k, v in data["env_kwargs"].items()
            if data["trained_on"]["env_kwargs"].get(k) != v
        }
        if overrides:
            env += " " + ", ".join(f"{k}={v}" for k, v in overrides.items())
        out.append(
            f"| {run_dir.name} | {env} | {name} | {wall_s} | {meta.get('total_steps', '?'):,} "
            f"| {100 * c['success_rate']:.1f} % | {100 * c['within_1mm']:.1f} % "
            f"| {_fmt(e['mean'])} | {_fmt(e['median'])} | {_fmt(e['p95'])} | {_fmt(e['max'])} "
            f"| {100 * ik['success_rate']:.1f} % | {_fmt(ik['error_mm']['median'])} "
            f"| {_fmt(ik['error_mm']['p95'])} | {_fmt(ik['error_mm']['max'])} "
            f"| {ik['cable_length_distance_mm']['median']:.3f} mm |"
        )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="cdcr-gym results", description=__doc__)
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR[:EVAL_NAME]")
    parser.add_argument(
        "--conditions", default=None, help="comma-separated condition names to show (default: all)"
    )
    args = parser.parse_args(argv)
    conditions = args.conditions.split(",") if args.conditions else None
    lines = [HEADER, "|" + "---|" * (HEADER.count("|") - 1)]
    for spec in args.runs:
        path, _, name = spec.partition(":")
        run_dir = Path(path)
        if not (run_dir / "run.json").is_file():
            print(f"error: RUN_DIR {path!r} has no run.json", file=sys.stderr)
            return 2
        if not (run_dir / f"{name or 'eval'}.json").is_file():
            print(f"error: {run_dir / (name or 'eval')}.json does not exist", file=sys.stderr)
            return 2
        lines.extend(rows(run_dir, name or "eval", conditions))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
