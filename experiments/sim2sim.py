"""Summarise zero-shot sim-to-sim evaluations: a small JSON, a figure and markdown table rows.

Usage::

    python -m experiments.sim2sim EVAL_JSON [EVAL_JSON ...] --out docs/figures/sim2real/NAME
        [--target-median-mm 3.0] [--target-success 0.9]

Each ``EVAL_JSON`` is a ``training.evaluate`` output (``RUN_DIR/eval_<tag>.json``), typically one
per seed of the same recipe on the same target env. Writes ``NAME.json`` (per run and condition:
success ≤ 5 mm, ≤ 1 mm, median and p95 final tip error of the policy and of the open-loop analytic
IK on the same goals, and whether the run meets the target in its headline condition) and
``NAME.png`` (median final error per condition and run, policy beside IK, log scale, with the
target line), and prints one markdown table row per run and condition.

The target is issue 11's: median final error ≤ 3 mm and ≥ 90 % of goals within 5 mm, in the
headline condition (the training start state at the training horizon).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from training.evaluate.conditions import read_eval
from training.run.argtypes import fraction, positive_float

__all__ = ["summarize_evals", "table_rows", "main"]


def _load(path: Path) -> dict[str, Any]:
    try:
        data = read_eval(path)
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"eval json {str(path)!r} cannot be read: {exc}") from None
    for key in ("run_dir", "env_id", "conditions", "headline_condition"):
        if key not in data:
            raise ValueError(
                f"eval json {str(path)!r} has no {key!r}: not a training.evaluate output"
            )
    return data


def summarize_evals(
    paths: Sequence[str | Path], target_median_mm: float = 3.0, target_success: float = 0.9
) -> dict[str, Any]:
    """The summary of evaluations ``paths`` (``training.evaluate`` JSONs).

    Args:
        paths: eval JSON files, at least one.
        target_median_mm: the target's largest median final error (mm, > 0).
        target_success: the target's smallest fraction of goals within the success radius
            (in (0, 1]).

    Returns:
        ``{"target": ..., "runs": [...], "all_meet_target": bool}``; each run holds its
        ``run_dir``, ``env_id``, ``env_kwargs``, ``episodes``, ``model_step``, ``command``,
        ``headline_condition``, ``meets_target`` and per condition the policy's and the IK's
        ``success_rate``, ``within_1mm``, ``median_mm``, ``p95_mm``.

    Raises:
        ValueError: no paths, a bad target, or a file that is not an evaluate JSON.
    """
    if not paths:
        raise ValueError("paths: give at least one eval json, got none")
    if not target_median_mm > 0.0:
        raise ValueError(f"target_median_mm must be > 0, got {target_median_mm!r}")
    if not 0.0 < target_success <= 1.0:
        raise ValueError(f"target_success must be in (0, 1], got {target_success!r}")
    runs = []
    for path in paths:
        data = _load(Path(path))
        conditions = {}
        for name, cond in data["conditions"].items():
            pol, ik = cond["policy"], cond.get("oracle", {})
            conditions[name] = {
                "success_rate": pol["success_rate"],
                "within_1mm": pol.get("within_1mm"),
                "median_mm": pol["final_distance_mm"]["median"],
                "p95_mm": pol["final_distance_mm"]["p95"],
                "ik_success_rate": ik.get("success_rate"),
                "ik_median_mm": ik.get("final_distance_mm", {}).get("median"),
                "ik_p95_mm": ik.get("final_distance_mm", {}).get("p95"),
            }
        head = conditions[data["headline_condition"]]
        meets = head["median_mm"] <= target_median_mm and head["success_rate"] >= target_success
        runs.append(
            {
                "eval_json": str(path),
                "run_dir": data["run_dir"],
                "env_id": data["env_id"],
                "env_kwargs": data.get("env_kwargs", {}),
                "episodes": data.get("episodes"),
                "model_step": data.get("model_step"),
                "command": data.get("command"),
                "headline_condition": data["headline_condition"],
                "meets_target": bool(meets),
                "conditions": conditions,
            }
        )
    return {
        "target": {"median_mm": target_median_mm, "success_rate": target_success},
        "runs": runs,
        "all_meet_target": all(r["meets_target"] for r in runs),
    }


def table_rows(summary: dict[str, Any]) -> list[str]:
    """Markdown rows ``| run | condition | ≤5 mm | ≤1 mm | median | p95 | IK ≤5 mm | IK median |``
    (errors in mm), one per run and condition, the headline condition marked with ``*``."""
    rows = []
    for run in summary["runs"]:
        for name, c in run["conditions"].items():
            mark = " *" if name == run["headline_condition"] else ""
            ik_ok = "–" if c["ik_success_rate"] is None else f"{100 * c['ik_success_rate']:.1f} %"
            ik_med = "–" if c["ik_median_mm"] is None else f"{c['ik_median_mm']:.2f}"
            rows.append(
                f"| {Path(run['run_dir']).name} | {name}{mark} | {100 * c['success_rate']:.1f} % | "
                f"{100 * c['within_1mm']:.1f} % | {c['median_mm']:.2f} | {c['p95_mm']:.2f} | "
                f"{ik_ok} | {ik_med} |"
            )
    return rows


def _figure(summary: dict[str, Any], path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    runs = summary["runs"]
    names = list(runs[0]["conditions"])
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    width = 0.8 / (len(runs) + 1)
    for k, run in enumerate(runs):
        xs = [i + k * width for i in range(len(names))]
        ax.bar(
            xs,
            [run["conditions"][n]["median_mm"] for n in names],
            width,
            label=f"PPO {Path(run['run_dir']).name}",
        )
    ik = [runs[0]["conditions"][n]["ik_median_mm"] for n in names]
    if all(v is not None for v in ik):
        xs = [i + len(runs) * width for i in range(len(names))]
        ax.bar(xs, ik, width, color="0.6", label="open-loop IK")
    ax.axhline(summary["target"]["median_mm"], color="k", ls=":", lw=1, label="target median")
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(names))], names)
    ax.set_yscale("log")
    ax.set_ylabel("median final tip error (mm)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.sim2sim", description=__doc__)
    parser.add_argument("evals", nargs="+", help="training.evaluate JSON files")
    parser.add_argument("--out", required=True, help="output stem: writes OUT.json and OUT.png")
    parser.add_argument("--target-median-mm", type=positive_float, default=3.0)
    parser.add_argument("--target-success", type=fraction, default=0.9)
    parser.add_argument("--title", default=None, help="figure title (default: env id + kwargs)")
    args = parser.parse_args(argv)
    try:
        summary = summarize_evals(args.evals, args.target_median_mm, args.target_success)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    summary["command"] = "python -m experiments.sim2sim " + " ".join(
        argv if argv is not None else sys.argv[1:]
    )
    out.with_suffix(".json").write_text(json.dumps(summary, indent=1) + "\n")
    first = summary["runs"][0]
    title = args.title or f"{first['env_id']} {first['env_kwargs']}"
    _figure(summary, out.with_suffix(".png"), title)
    print("| run | condition | ≤5 mm | ≤1 mm | median | p95 | IK ≤5 mm | IK median |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(table_rows(summary)))
    print(f"all runs meet the target: {summary['all_meet_target']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
