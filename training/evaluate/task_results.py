"""Collect the task evaluations (Track, Pose, Obstacle) of several runs into one small JSON.

Usage::

    python -m training.evaluate.task_results RUN [RUN ...] --out docs/figures/tasks/ppo_results.json

``--tag TAG`` collects ``eval_<TAG>.json`` instead (an evaluation with ``cdcr-gym evaluate RUN
--tag TAG``, e.g. under other env kwargs such as ``--env-kwarg safety_filter=true``); each
record then names the tag and the evaluated env kwargs.

Each ``RUN`` is a training run directory evaluated by ``python -m training.evaluate RUN``
(it holds ``eval.json`` with the task's metrics for the policy beside its oracle's on the same
episodes, and ``run.json`` with the training steps and wall time). Writes ``--out``: per run
the task, env id, seed, training steps and wall time (s), the evaluate command, and per
evaluation condition (``straight_100steps``, ...; ``straight_h100`` in older files) the summaries of ``training.run.metrics``
(``policy``, ``oracle`` and, for Obstacle, ``reach_ik``). With ``--figures DIR`` the path
figures ``RUN/eval/<condition>_paths.png`` are copied to
``DIR/ppo_<task>_seed<S>_<condition>_paths.png``. Prints a markdown table, one row per run and
condition: the task's headline numbers, policy beside oracle.

Error tracking RMS and distances are in mm, angles in degrees, rates in [0, 1].
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

from training.evaluate.conditions import canonical_condition, read_eval

__all__ = ["collect", "headline", "markdown_table", "main"]


class ResultsError(ValueError):
    """A run directory that cannot be collected (missing or non-task evaluation)."""


def collect(run_dirs: list[Path], tag: str | None = None) -> list[dict[str, Any]]:
    """One record per run (see the module docstring), in the given order; ``tag``: read
    ``eval_<tag>.json`` instead of ``eval.json``.

    Raises:
        ResultsError: a run without ``eval.json``/``run.json``, or evaluated on Reach.
    """
    records = []
    name = "eval.json" if tag is None else f"eval_{tag}.json"
    for run in run_dirs:
        ev_path, meta_path = run / name, run / "run.json"
        for path in (ev_path, meta_path):
            if not path.is_file():
                raise ResultsError(f"RUN {str(run)!r}: {path.name} does not exist")
        ev = read_eval(ev_path)
        if "task" not in ev:
            raise ResultsError(f"RUN {str(run)!r}: {name} is not a task evaluation (Reach?)")
        meta = json.loads(meta_path.read_text())
        tagged = {} if tag is None else {"eval_tag": tag, "env_kwargs": ev.get("env_kwargs")}
        records.append(
            {
                **tagged,
                "run": run.name,
                "task": ev["task"],
                "env_id": ev["env_id"],
                "seed": meta["seed"],
                "config": meta["name"],
                "train_steps": meta["total_steps"],
                "train_wall_time_s": meta["total_wall_time_s"],
                "model_step": ev["model_step"],
                "episodes": ev["episodes"],
                "eval_seed": ev["seed"],
                "eval_command": ev["command"],
                "conditions": ev["conditions"],
            }
        )
    return records


def headline(task: str, s: dict[str, Any]) -> str:
    """The task's headline numbers of one summary (``training.run.metrics.summarize_task``)."""
    success = f"success {100 * s['success_rate']:.0f} %"
    if task == "Track":
        rms = s["tracking_rms_mm"]
        return f"tracking RMS mean {rms['mean']:.2f} mm (max {rms['max']:.2f}), {success}"
    if task == "Pose":
        return (
            f"{success}; distance median {s['final_distance_mm']['median']:.2f} mm, "
            f"angle median {s['final_angle_deg']['median']:.2f}°"
        )
    if task == "Obstacle":
        filtered = s.get("filtered_step_fraction")
        return (
            f"{success}; collisions {100 * s['collision_rate']:.0f} % of episodes "
            f"({s['collisions_in_successful_episodes']} in successful ones); distance median "
            f"{s['final_distance_mm']['median']:.1f} mm"
            + ("" if filtered is None else f"; filter on {100 * filtered:.1f} % of steps")
        )
    return f"{success}; distance median {s['final_distance_mm']['median']:.2f} mm"


def markdown_table(records: list[dict[str, Any]]) -> str:
    """Rows: task, seed, condition, training steps and wall time, policy, oracle."""
    lines = [
        "| task | seed | start | training | learned policy | oracle (same episodes) | reach IK |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in records:
        for name, rows in r["conditions"].items():
            lines.append(
                f"| {r['task']} | {r['seed']} | {name} | {r['train_steps'] / 1e6:.1f} M steps, "
                f"{r['train_wall_time_s']:.0f} s | {headline(r['task'], rows['policy'])} | "
                f"{headline(r['task'], rows['oracle'])} | "
                f"{headline(r['task'], rows['reach_ik']) if 'reach_ik' in rows else '–'} |"
            )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="cdcr-gym task-results", description=__doc__.split("\n")[0]
    )
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN")
    parser.add_argument("--out", type=Path, required=True, help="output JSON file")
    parser.add_argument("--figures", type=Path, default=None, help="copy path figures here")
    parser.add_argument(
        "--tag", default=None, help="collect eval_<TAG>.json (cdcr-gym evaluate --tag) instead"
    )
    args = parser.parse_args(argv)
    try:
        records = collect(args.runs, args.tag)
    except ResultsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    command = " ".join(shlex.quote(a) for a in ["cdcr-gym", "task-results", *argv])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"command": command, "runs": records}, indent=1) + "\n")
    if args.figures is not None:
        args.figures.mkdir(parents=True, exist_ok=True)
        fig_dir = "eval" if args.tag is None else f"eval_{args.tag}"
        for run, r in zip(args.runs, records, strict=True):
            for name in r["conditions"]:
                src = run / fig_dir / f"{name}_paths.png"
                old = [p for p in (run / fig_dir).glob("*_paths.png") if p.stem[:-6] != name]
                for path in old:  # an evaluation of before the renaming: straight_h100_paths.png
                    if canonical_condition(path.stem[: -len("_paths")]) == name:
                        src = path
                if src.is_file():
                    suffix = "" if args.tag is None else f"_{args.tag}"
                    dst = f"ppo_{r['task'].lower()}_seed{r['seed']}_{name}{suffix}_paths.png"
                    shutil.copyfile(src, args.figures / dst)
    print(markdown_table(records))
    return 0


if __name__ == "__main__":
    sys.exit(main())
