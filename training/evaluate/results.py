"""Markdown tables of evaluated runs, straight from their ``run.json`` and ``eval*.json``.

Usage::

    cdcr-gym results RUN_DIR[:EVAL_NAME] ... [--conditions straight_100steps,...] [--wide]

``EVAL_NAME`` picks the evaluation file (``eval`` = ``eval.json``, the default;
``eval_BulletReach-v0`` = ``eval_BulletReach-v0.json``). Reach evaluations: one row per run and
condition, the policy's final-error statistics and the analytic-IK oracle's on the same goals;
``--wide`` adds the training command's wall time and steps (from ``run.json``) and the remaining
statistics. Track, Pose and Obstacle evaluations: one table per task, one row per run,
condition and policy (the trained policy, the task's oracle and the baselines), with the task's
own numbers. A legend under each table explains its columns.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from training.evaluate import tables
from training.evaluate.conditions import canonical_condition, read_eval

__all__ = ["COLUMNS", "records", "task_records", "rows", "main"]


def _fmt(x: float) -> str:
    return f"{x:.3f}" if x < 10 else f"{x:.1f}"


def _err(who: str, stat: str) -> Any:
    return lambda r: _fmt((r["cond"] if who == "policy" else r["cond"][who])["error_mm"][stat])


def _pct(key: str, who: str = "policy") -> Any:
    return lambda r: tables.pct((r["cond"] if who == "policy" else r["cond"][who])[key])


C = tables.Column
#: the columns; a record (:func:`records`) has run, env, wall, steps, name, cond (one condition)
COLUMNS = [
    C("run", "the run directory", lambda r: r["run"]),
    C("on", "the env evaluated on (and env kwargs that differ from training)", lambda r: r["env"]),
    C("condition", "starting shape and episode length", lambda r: r["name"]),
    C("train time", "the training command's wall time", lambda r: r["wall"], narrow=False),
    C("steps", "training env steps", lambda r: r["steps"], narrow=False),
    C(
        "≤5mm",
        "the policy's episodes with a final tip error within the success threshold (5 mm unless "
        "the env sets another)",
        _pct("success_rate"),
    ),
    C("≤1mm", "... within 1 mm", _pct("within_1mm"), narrow=False),
    C("mean", "mean final tip error, mm", _err("policy", "mean"), narrow=False),
    C("median", "median final tip error, mm", _err("policy", "median")),
    C("p95", "95th percentile of the final tip error, mm", _err("policy", "p95")),
    C("max", "largest final tip error, mm", _err("policy", "max"), narrow=False),
    C(
        "IK ≤5mm",
        "success of the analytic IK on the same goals and starts",
        _pct("success_rate", "ik"),
        narrow=False,
    ),
    C(
        "IK med",
        "the analytic IK's median final tip error on the same goals, mm",
        _err("ik", "median"),
    ),
    C("IK p95", "its 95th percentile, mm", _err("ik", "p95"), narrow=False),
    C("IK max", "its largest error, mm", _err("ik", "max"), narrow=False),
    C(
        "ΔL IK",
        "median distance of the policy's final cable lengths from the IK solution (Euclidean "
        "over the cables), mm",
        lambda r: f"{r['cond']['ik']['cable_length_distance_mm']['median']:.3f}",
        narrow=False,
    ),
]


def records(
    run_dir: Path, eval_name: str = "eval", conditions: list[str] | None = None
) -> list[dict[str, Any]]:
    """One record per condition of one run's evaluation file (see :data:`COLUMNS`)."""
    meta: dict[str, Any] = json.loads((run_dir / "run.json").read_text())
    data: dict[str, Any] = read_eval(run_dir / f"{eval_name}.json")
    wall = meta.get("total_wall_time_s")
    steps = meta.get("total_steps")
    env = data["env_id"].split("/")[-1]
    trained = data["trained_on"]["env_kwargs"]
    overrides = {k: v for k, v in data["env_kwargs"].items() if trained.get(k) != v}
    if overrides:
        env += " " + ", ".join(f"{k}={v}" for k, v in overrides.items())
    wanted = {canonical_condition(c) for c in conditions} if conditions else None
    return [
        {
            "run": run_dir.name,
            "env": env,
            "wall": f"{wall / 60:.1f} min" if wall is not None else "?",
            "steps": f"{steps:,}" if steps is not None else "?",
            "name": name,
            "cond": cond,
        }
        for name, cond in data["conditions"].items()
        if wanted is None or name in wanted
    ]


def task_records(
    run_dir: Path, eval_name: str = "eval", conditions: list[str] | None = None
) -> tuple[str, list[tuple[str, str, dict[str, Any]]]]:
    """The task and the rows ``(run condition, policy, summary)`` of a Track/Pose/Obstacle
    evaluation file (rows for :func:`training.evaluate.tables.task_columns`)."""
    data: dict[str, Any] = read_eval(run_dir / f"{eval_name}.json")
    wanted = {canonical_condition(c) for c in conditions} if conditions else None
    return data["task"], [
        (f"{run_dir.name} {name}", who, summary)
        for name, block in data["conditions"].items()
        if wanted is None or name in wanted
        for who, summary in block.items()
    ]


def rows(
    run_dir: Path, eval_name: str = "eval", conditions: list[str] | None = None, wide: bool = False
) -> list[str]:
    """Markdown table rows (without the header) for one run's evaluation file."""
    table = tables.markdown_table(COLUMNS, records(run_dir, eval_name, conditions), wide)
    return table.splitlines()[2:]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="cdcr-gym results",
        description=__doc__.split("\n\n")[0],
        epilog=tables.legend(COLUMNS, wide=True),
    )
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR[:EVAL_NAME]")
    parser.add_argument(
        "--conditions", default=None, help="comma-separated condition names to show (default: all)"
    )
    parser.add_argument(
        "--wide", action="store_true", help="every column (default: the ones that fit 100 columns)"
    )
    args = parser.parse_args(argv)
    conditions = args.conditions.split(",") if args.conditions else None
    found: list[dict[str, Any]] = []
    by_task: dict[str, list[tuple[str, str, dict[str, Any]]]] = {}
    for spec in args.runs:
        path, _, name = spec.partition(":")
        run_dir = Path(path)
        if not (run_dir / "run.json").is_file():
            print(f"error: RUN_DIR {path!r} has no run.json", file=sys.stderr)
            return 2
        if not (run_dir / f"{name or 'eval'}.json").is_file():
            print(f"error: {run_dir / (name or 'eval')}.json does not exist", file=sys.stderr)
            return 2
        if "task" in read_eval(run_dir / f"{name or 'eval'}.json"):
            task, task_rows = task_records(run_dir, name or "eval", conditions)
            by_task.setdefault(task, []).extend(task_rows)
        else:
            found.extend(records(run_dir, name or "eval", conditions))
    blocks = []
    if found:
        blocks.append((COLUMNS, found))
    for task, task_rows in by_task.items():
        blocks.append(
            (tables.task_columns(task, ("run", "the run directory and condition")), task_rows)
        )
    for k, (columns, table_rows) in enumerate(blocks):
        if k:
            print()
        print(tables.markdown_table(columns, table_rows, args.wide))
        print()
        print(tables.legend(columns, args.wide))
    return 0


if __name__ == "__main__":
    sys.exit(main())
