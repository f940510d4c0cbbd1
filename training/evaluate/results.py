"""Tables and a collected JSON of evaluated runs, straight from their ``run.json`` and ``eval*.json``.

Usage::

    cdcr-gym results RUN_DIR[:EVAL_NAME] ... [--conditions straight_100steps,...] [--wide]
                     [--tag TAG] [--out FILE.json] [--figures DIR]

``EVAL_NAME`` picks the evaluation file (``eval`` = ``eval.json``, the default;
``eval_BulletReach-v0`` = ``eval_BulletReach-v0.json``); ``--tag TAG`` picks ``eval_<TAG>.json``
for every run (an evaluation with ``cdcr-gym evaluate RUN --tag TAG``). Every task reads the same
way (``cdcr-gym evaluate`` writes one shape; files of before it are read by
:func:`training.evaluate.conditions.read_eval`): one Markdown table per task, one row per run,
condition and policy (the trained policy, the task's oracle and the baselines on the same
episodes) with the task's columns (:func:`training.evaluate.tables.task_columns`); ``--wide``
adds the training command's wall time and steps (from ``run.json``) and the remaining numbers.
A legend under each table explains its columns.

``--out FILE.json`` also writes the collected evaluations: per run the task, env id, seed,
training steps and wall time (s), the evaluate command and its conditions' summaries
(:func:`collect`). With ``--figures DIR`` the
path figures ``RUN/eval/<condition>_paths.png`` are copied to
``DIR/ppo_<task>_seed<S>_<condition>[_<tag>]_paths.png``.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

from training.evaluate import tables
from training.evaluate.conditions import canonical_condition, read_eval

__all__ = ["ResultsError", "collect", "records", "columns", "main"]


class ResultsError(ValueError):
    """A run directory that cannot be read (missing ``run.json`` or evaluation file)."""


def _paths(run_dir: Path, eval_name: str) -> tuple[Path, Path]:
    ev_path, meta_path = run_dir / f"{eval_name}.json", run_dir / "run.json"
    for path in (meta_path, ev_path):
        if not path.is_file():
            raise ResultsError(f"RUN_DIR {str(run_dir)!r}: {path.name} does not exist")
    return ev_path, meta_path


def records(
    run_dir: Path, eval_name: str = "eval", conditions: list[str] | None = None
) -> tuple[str, list[tuple[str, str, dict[str, Any], dict[str, str]]]]:
    """The task and the table rows of one run's evaluation file: ``(run and condition, policy,
    summary, run facts)``, the facts being ``on`` (the env evaluated on, with the env kwargs
    that differ from training), ``wall`` and ``steps`` (training, from ``run.json``)."""
    ev_path, meta_path = _paths(run_dir, eval_name)
    meta: dict[str, Any] = json.loads(meta_path.read_text())
    data = read_eval(ev_path)
    wall, steps = meta.get("total_wall_time_s"), meta.get("total_steps")
    env = str(data.get("env_id", "?")).split("/")[-1]
    trained = (data.get("trained_on") or {}).get("env_kwargs") or {}
    overrides = {k: v for k, v in (data.get("env_kwargs") or {}).items() if trained.get(k) != v}
    if overrides and trained:
        env += " " + ", ".join(f"{k}={v}" for k, v in overrides.items())
    facts = {
        "on": env,
        "wall": f"{wall / 60:.1f} min" if wall is not None else "?",
        "steps": f"{steps:,}" if steps is not None else "?",
    }
    wanted = {canonical_condition(c) for c in conditions} if conditions else None
    rows = [
        (f"{run_dir.name} {name}", who, summary, facts)
        for name, cond in data["conditions"].items()
        if wanted is None or name in wanted
        for who, summary in cond.items()
        if isinstance(summary, dict)
    ]
    return str(data["task"]), rows


def columns(task: str) -> list[tables.Column]:
    """The columns of one task's table (rows of :func:`records`)."""
    C = tables.Column
    cols = tables.task_columns(task, ("run", "the run directory and condition"))
    return [
        cols[0],
        C(
            "on",
            "the env evaluated on (and env kwargs that differ from training)",
            lambda r: r[3]["on"],
            narrow=False,
        ),
        C("train time", "the training command's wall time", lambda r: r[3]["wall"], narrow=False),
        C("steps", "training env steps", lambda r: r[3]["steps"], narrow=False),
        *cols[1:],
    ]


def collect(run_dirs: list[Path], tag: str | None = None) -> list[dict[str, Any]]:
    """One record per run, in the given order (module docstring); ``tag``: read
    ``eval_<tag>.json`` instead of ``eval.json``.

    Raises:
        ResultsError: a run without ``run.json`` or the evaluation file.
    """
    out = []
    name = "eval" if tag is None else f"eval_{tag}"
    for run in run_dirs:
        ev_path, meta_path = _paths(run, name)
        ev = read_eval(ev_path)
        meta = json.loads(meta_path.read_text())
        tagged = {} if tag is None else {"eval_tag": tag, "env_kwargs": ev.get("env_kwargs")}
        out.append(
            {
                **tagged,
                "run": run.name,
                "task": ev["task"],
                "env_id": ev["env_id"],
                "seed": meta.get("seed"),
                "config": meta.get("name"),
                "train_steps": meta.get("total_steps"),
                "train_wall_time_s": meta.get("total_wall_time_s"),
                "model_step": ev.get("model_step"),
                "episodes": ev.get("episodes"),
                "eval_seed": ev.get("seed"),
                "eval_command": ev.get("command"),
                "conditions": ev["conditions"],
            }
        )
    return out


def _copy_figures(
    runs: list[Path], collected: list[dict[str, Any]], tag: str | None, dst: Path
) -> None:
    dst.mkdir(parents=True, exist_ok=True)
    fig_dir = "eval" if tag is None else f"eval_{tag}"
    for run, r in zip(runs, collected, strict=True):
        for name in r["conditions"]:
            src = run / fig_dir / f"{name}_paths.png"
            for path in (run / fig_dir).glob("*_paths.png"):  # straight_h100_paths.png of before
                if canonical_condition(path.stem[: -len("_paths")]) == name:
                    src = path
            if src.is_file():
                suffix = "" if tag is None else f"_{tag}"
                shutil.copyfile(
                    src, dst / f"ppo_{r['task'].lower()}_seed{r['seed']}_{name}{suffix}_paths.png"
                )


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="cdcr-gym results", description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR[:EVAL_NAME]")
    parser.add_argument(
        "--conditions", default=None, help="comma-separated condition names to show (default: all)"
    )
    parser.add_argument(
        "--wide", action="store_true", help="every column (default: the ones that fit 100 columns)"
    )
    parser.add_argument(
        "--tag", default=None, help="read eval_<TAG>.json (cdcr-gym evaluate --tag) of every run"
    )
    parser.add_argument("--out", type=Path, default=None, help="also write the collected JSON")
    parser.add_argument("--figures", type=Path, default=None, help="copy the path figures here")
    args = parser.parse_args(argv)
    conditions = args.conditions.split(",") if args.conditions else None
    by_task: dict[str, list[Any]] = {}
    run_dirs = []
    try:
        for spec in args.runs:
            path, _, name = spec.partition(":")
            if name and args.tag:
                raise ResultsError(f"RUN_DIR {spec!r}: give :EVAL_NAME or --tag, not both")
            name = name or ("eval" if args.tag is None else f"eval_{args.tag}")
            task, rows = records(Path(path), name, conditions)
            by_task.setdefault(task, []).extend(rows)
            run_dirs.append(Path(path))
        collected = collect(run_dirs, args.tag) if args.out or args.figures else []
    except ResultsError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.out is not None:
        command = " ".join(shlex.quote(a) for a in ["cdcr-gym", "results", *argv])
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"command": command, "runs": collected}, indent=1) + "\n")
    if args.figures is not None:
        _copy_figures(run_dirs, collected, args.tag, args.figures)
    for k, (task, rows) in enumerate(by_task.items()):
        cols = columns(task)
        if k:
            print()
        print(f"{task}:")
        print()
        print(tables.markdown_table(cols, rows, args.wide))
        print()
        print(tables.legend(cols, args.wide))
    return 0


if __name__ == "__main__":
    sys.exit(main())
