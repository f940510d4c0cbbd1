"""Aggregate a sweep: IQM with stratified-bootstrap confidence intervals, performance profiles.

Usage::

    cdcr-gym aggregate SWEEP_OUT [--doc docs/experiments/benchmark.md] [--reps 50000]

``SWEEP_OUT`` is a sweep's output directory (``runs/sweeps/<name>``, holding ``sweep.json``,
see :mod:`training.sweep`). Prints markdown tables and writes ``SWEEP_OUT/aggregate.json``;
``--doc PAGE`` also writes the benchmark page ``PAGE``, its figures in ``<figures>/<page name>/``
and its data ``<figures>/<page name>/results.json``, where ``<figures>`` is the ``figures/``
folder of the page's folder or, if it has none, of its parent folder (the docs' one for
``docs/experiments/benchmark.md``: ``docs/figures/benchmark/``); the page links them relative
to its own folder (``../figures/benchmark/iqm.png``) (:func:`figures_dir`).

**Scores.** One scalar per run and evaluation condition (``eval.json``'s ``conditions``, e.g.
``straight_100steps``; ``straight_h100`` in older files): the median final tip error (mm), the fraction of goals within 5 mm
(``success_rate``) and within 1 mm. Runs are grouped by (task = env id, algorithm = the config's
``algo`` and the sweep variant); the seeds of a group are its runs.

**Estimator.** The interquartile mean (IQM: the mean of the middle 50 % of the runs, the
``trim_mean(·, 0.25)`` of Agarwal et al., NeurIPS 2021, "Deep RL at the edge of the statistical
precipice") and its 95 % percentile confidence interval from a *stratified* bootstrap: each
bootstrap sample redraws, with replacement, the same number of runs *within each task*, pools
them and takes the IQM (50 000 samples by default, as rliable's ``get_interval_estimates``).
Per (task, algorithm) there is one stratum, so it is the ordinary bootstrap over seeds; the
across-task aggregate of the scale-free rates uses one stratum per task. The estimator is
written here (``iqm``, ``stratified_bootstrap_ci``: some twenty lines of numpy) instead of
depending on rliable: rliable is archived, pins old numpy/scipy/arch releases, and the method is
small enough to test against hand-computed values (``tests/test_aggregate.py``); it follows
rliable's definitions (scipy's trimming rule: ``int(0.25 n)`` runs cut at each end, so with
n ≤ 3 runs the IQM is the mean; percentile intervals).

**Performance profiles.** For error levels τ, the fraction of runs whose median final error is
≤ τ, with a stratified-bootstrap 95 % band (rliable's run-score distributions, for an error:
lower is better).

**Target.** The sweep's ``target`` thresholds (e.g. ``success_rate: 0.9``) are looked up in each
run's periodic evaluations (``eval_log.csv``): the env steps and training wall time of the first
evaluation meeting every threshold, or "not reached" within the budget.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from collections import defaultdict
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from training.run.argtypes import non_negative_int, positive_int
from training.sweep.figures import plot_curves, plot_iqm, plot_performance_profiles
from training.sweep.scores import (
    METRICS,
    RATE_METRICS,
    SUCCESS,
    RunResult,
    aggregate,
    condition_order,
    group_metrics,
    load_runs,
)
from training.sweep.statistics import (
    iqm,
    performance_profile,
    stratified_bootstrap,
    stratified_bootstrap_ci,
)

__all__ = [
    "iqm",
    "stratified_bootstrap",
    "stratified_bootstrap_ci",
    "performance_profile",
    "RunResult",
    "load_runs",
    "aggregate",
    "main",
]


# -- tables -------------------------------------------------------------------------------------
def _fmt_metric(metric: str, value: float) -> str:
    if METRICS[metric][1] == "%":
        return f"{100 * value:.1f} %"
    return f"{value:.3g}" if value < 100 else f"{value:.0f}"


def _fmt_ci(metric: str, m: dict[str, Any] | None) -> str:
    if m is None:
        return "–"
    low, high = m["ci"]
    unit = {"mm": " mm", "°": "°"}.get(METRICS[metric][1], "")
    if METRICS[metric][1] == "%":
        return f"{100 * m['iqm']:.1f} [{100 * low:.1f}, {100 * high:.1f}] %"
    return f"{_fmt_metric(metric, m['iqm'])} [{_fmt_metric(metric, low)}, {_fmt_metric(metric, high)}]{unit}"


def _fmt_value(metric: str, value: float | None) -> str:
    if value is None:
        return "–"
    unit = {"mm": " mm", "°": "°"}.get(METRICS[metric][1], "")
    return _fmt_metric(metric, value) + ("" if METRICS[metric][1] == "%" else unit)


def iqm_table(result: dict[str, Any]) -> list[str]:
    """Markdown: per task, one row per (algorithm, condition) with the IQM [95 % CI] of each of
    the task's metrics, then the task's baselines (oracle, analytic IK: one value, the same
    episodes for every run). One table per task, separated by a blank line and a task heading."""
    lines: list[str] = []
    tasks = sorted({g["task"] for g in result["groups"]})
    for task in tasks:
        groups = [g for g in result["groups"] if g["task"] == task]
        metrics = group_metrics(groups)
        if len(tasks) > 1:
            lines += [f"**{task}**", ""]
        lines += [
            "| algorithm | condition | runs | "
            + " | ".join(f"{METRICS[m][0]}, IQM [95 % CI]" for m in metrics)
            + " |",
            "|---|---|---|" + "---|" * len(metrics),
        ]
        for g in groups:
            lines.append(
                f"| {g['algo']} | {g['condition']} | {g['runs']} "
                + "".join(f"| {_fmt_ci(m, g.get(m))} " for m in metrics)
                + "|"
            )
        seen = set()
        for g in groups:
            for name, scores in (g.get("baselines") or {}).items():
                if (name, g["condition"]) in seen:
                    continue
                seen.add((name, g["condition"]))
                lines.append(
                    f"| *{name}* | {g['condition']} | – "
                    + "".join(f"| {_fmt_value(m, scores.get(m))} " for m in metrics)
                    + "|"
                )
        lines.append("")
    return lines[:-1] if lines else lines


def aggregate_table(result: dict[str, Any]) -> list[str]:
    """Markdown: the across-task IQM of the rates per algorithm (stratified over tasks)."""
    if not result["aggregate"]:
        return []
    metrics = [m for m in RATE_METRICS if any(m in a for a in result["aggregate"])]
    lines = [
        "| algorithm | condition | tasks | runs | "
        + " | ".join(f"{METRICS[m][0]}, IQM [95 % CI]" for m in metrics)
        + " |",
        "|---|---|---|---|" + "---|" * len(metrics),
    ]
    for a in result["aggregate"]:
        lines.append(
            f"| {a['algo']} | {a['condition']} | {', '.join(a['tasks'])} | {a['runs']} "
            + "".join(f"| {_fmt_ci(m, a.get(m))} " for m in metrics)
            + "|"
        )
    return lines


def runs_table(runs: list[RunResult], target: dict[str, float]) -> list[str]:
    """Markdown: one row per run — budget use, target, final scores (or the failure)."""
    conds = sorted({c for r in runs for c in r.scores}, key=condition_order)
    lines = [
        "| task | algorithm | seed | status | env steps | train wall time | steps to target "
        "| wall time to target | " + " | ".join(f"median error {c}" for c in conds) + " |",
        "|---|---|---|---|---|---|---|---|" + "---|" * len(conds),
    ]
    for r in sorted(runs, key=lambda r: (r.task, r.algo, r.seed)):
        hit = r.to_target
        tgt_steps = f"{int(hit['steps']):,}" if hit is not None else "not reached"
        tgt_wall = f"{hit['wall_time_s']:.0f} s" if hit is not None else "–"
        if not target:
            tgt_steps = tgt_wall = "(no target)"
        steps = f"{r.steps:,}" if r.steps is not None else "–"
        wall = f"{r.train_wall_time_s:.0f} s" if r.train_wall_time_s is not None else "–"
        errs = " | ".join(
            f"{r.scores[c]['median_error_mm']:.3g} mm" if c in r.scores else "–" for c in conds
        )
        lines.append(
            f"| {r.task} | {r.algo} | {r.seed} | {r.status} | {steps} | {wall} | {tgt_steps} "
            f"| {tgt_wall} | {errs} |"
        )
    return lines


def target_table(runs: list[RunResult], target: dict[str, float]) -> list[str]:
    """Markdown: per (task, algorithm): runs reaching the target, steps/time to it, budget use."""
    by_group: dict[tuple[str, str], list[RunResult]] = defaultdict(list)
    for r in runs:
        if r.status == "complete":
            by_group[(r.task, r.algo)].append(r)
    lines = [
        "| task | algorithm | runs | env steps in the budget (median) | reached the target "
        "| env steps to target (median [min, max]) | wall time to target (median [min, max]) |",
        "|---|---|---|---|---|---|---|",
    ]
    for (task, algo), members in sorted(by_group.items()):
        steps = [r.steps for r in members if r.steps is not None]
        hit = [r.to_target for r in members if r.to_target is not None]
        if hit:
            s = np.array([h["steps"] for h in hit])
            w = np.array([h["wall_time_s"] for h in hit])
            s_txt = f"{np.median(s):,.0f} [{s.min():,.0f}, {s.max():,.0f}]"
            w_txt = f"{np.median(w):.0f} s [{w.min():.0f}, {w.max():.0f}]"
        else:
            s_txt = w_txt = "–"
        lines.append(
            f"| {task} | {algo} | {len(members)} | "
            f"{np.median(steps):,.0f} | {len(hit)}/{len(members)} | {s_txt} | {w_txt} |"
            if steps
            else f"| {task} | {algo} | {len(members)} | – | {len(hit)}/{len(members)} "
            f"| {s_txt} | {w_txt} |"
        )
    return lines


def parts_table(summary: dict[str, Any], runs: list[RunResult]) -> list[str]:
    """Markdown: per part of a sweep run in parts — its task, budget, how many trials ran, when,
    on which machine, for how long, and the env steps each algorithm reached in the budget."""
    spec_parts = (summary.get("spec") or {}).get("parts") or {}
    common = (summary.get("spec") or {}).get("set") or {}
    lines = [
        "| part | task | budget (train wall time) | trials complete | ran (UTC) | machine "
        "| trial time (train + evaluate, sum over trials) | env steps reached (median per algorithm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, part in spec_parts.items():
        members = [r for r in runs if r.part == name]
        done = [r for r in members if r.status == "complete"]
        budget = {**common, **(part.get("set") or {})}.get("runtime.max_wall_time_s")
        tasks = ", ".join(sorted({r.task for r in members})) or "?"
        if done:
            starts = sorted(r.start for r in done if r.start)
            ends = sorted(r.end for r in done if r.end)
            when = (
                f"{starts[0][:16].replace('T', ' ')} – {ends[-1][:16].replace('T', ' ')}"
                if starts and ends
                else "?"
            )
            hosts = ", ".join(sorted({r.host for r in done if r.host})) or "?"
            total = sum(r.trial_wall_time_s or 0.0 for r in done)
            by_algo: dict[str, list[int]] = defaultdict(list)
            for r in done:
                if r.steps is not None:
                    by_algo[r.algo].append(r.steps)
            steps = "; ".join(
                f"{algo} {np.median(v) / 1e6:.2f} M"
                if np.median(v) >= 1e5
                else f"{algo} {np.median(v) / 1e3:.0f} k"
                for algo, v in sorted(by_algo.items())
            )
            ran = f"{when} | {hosts} | {total / 3600:.2f} h | {steps}"
        else:
            ran = "not run yet | – | – | –"
        budget_txt = f"{budget:g} s" if budget else "the configs' steps"
        lines.append(f"| {name} | {tasks} | {budget_txt} | {len(done)}/{len(members)} | {ran} |")
    return lines


# -- the benchmark page -------------------------------------------------------------------------
def _machine(summary: dict[str, Any], runs: list[RunResult]) -> str:
    loads = [x for r in runs for x in r.loadavg]
    cpus = {t.get("cpu_count") for t in summary["trials"] if t.get("cpu_count")}
    load = (
        f"1-minute load average at the trials' starts and ends: median {np.median(loads):.2f}, "
        f"range {min(loads):.2f}–{max(loads):.2f}"
        if loads
        else "load average not recorded"
    )
    hosts = sorted({r.host for r in runs if r.host})
    return f"{', '.join(hosts) or '?'}, {', '.join(map(str, sorted(cpus)))} CPU cores; {load}"


def machine_sharing(summary: dict[str, Any], runs: list[RunResult], max_conc: int | None) -> str:
    """Whether the recorded load says other jobs shared the machine with the sweep's trials:
    a median 1-minute load above the trials running at once (``max_conc``, else the cores) + 0.5."""
    loads = [x for r in runs for x in r.loadavg]
    cpus = [t["cpu_count"] for t in summary["trials"] if t.get("cpu_count")]
    own = max_conc or (max(cpus) if cpus else None)
    if not loads or own is None:
        return "Whether other jobs shared the machine is unknown (no load recorded)."
    if float(np.median(loads)) <= own + 0.5:
        return (
            f"That load is the sweep's own {own} concurrent trial{'s' if own > 1 else ''}; "
            "the steps each run reached are in the tables."
        )
    return (
        "The machine was shared with other jobs while the sweep ran, so the wall-clock budget "
        "bought fewer env steps than on an idle machine; the steps each run reached are in the "
        "tables."
    )


def figures_dir(page: Path) -> tuple[Path, str]:
    """Where the figures of the page ``page`` go, and the link prefix the page uses for them.

    The folder is ``<D>/figures/<page stem>`` with ``D`` the page's folder if it holds a
    ``figures/`` folder, else its parent folder if that holds one (a page of a subsection of the
    docs, such as ``docs/experiments/``), else the page's folder; the prefix is that folder relative to the page's folder, with ``/`` separators
    (``docs/experiments/benchmark.md`` -> ``docs/figures/benchmark``, ``../figures/benchmark``).
    """
    folder = page.resolve().parent
    root = next((d for d in (folder, folder.parent) if (d / "figures").is_dir()), folder)
    fig_dir = root / "figures" / page.stem
    prefix = Path(os.path.relpath(fig_dir, folder)).as_posix()
    return fig_dir, prefix


def write_doc(
    page: Path,
    sweep_dir: Path,
    summary: dict[str, Any],
    runs: list[RunResult],
    result: dict[str, Any],
    argv: list[str],
    reps: int,
    note: str | None = None,
) -> None:
    """The benchmark page, its figures and its data (see the module docstring); ``note``: a
    paragraph placed under the page's introduction (e.g. why the budget is what it is)."""
    fig_dir, rel = figures_dir(page)
    fig_dir.mkdir(parents=True, exist_ok=True)
    plot_performance_profiles(runs, fig_dir / "performance_profiles.png")
    plot_iqm(result, fig_dir / "iqm.png")
    plot_curves(runs, fig_dir / "learning_curves.png")
    spec = summary.get("spec", {})
    target = spec.get("target") or {}
    budget = (spec.get("set") or {}).get("runtime.max_wall_time_s")
    parts = spec.get("parts") or {}
    ran = [r for r in runs if r.status != "not run"]
    per_group = defaultdict(int)
    for r in runs:
        if r.status == "complete":
            per_group[(r.task, r.algo)] += 1
    n_per_group = sorted(set(per_group.values()))
    sweep_file = next(
        (a for a in shlex.split(summary.get("command", "")) if a.endswith((".yaml", ".yml"))),
        "?",
    )
    # "cdcr-gym sweep ARGS", or "python -m training.sweep ARGS" in older sweeps
    words = shlex.split(summary.get("command", ""))
    for name in ("training.sweep", "sweep"):
        if name in words:
            words = words[words.index(name) + 1 :]
            break
    sweep_cmd = "cdcr-gym sweep " + " ".join(words)
    agg_cmd = "cdcr-gym aggregate " + " ".join(shlex.quote(a) for a in argv)
    n_ok = sum(r.status == "complete" for r in runs)  # of every trial, "not run" ones included
    concurrency = summary.get("executor", "ray")
    cpus = spec.get("resources", {}).get("cpus_per_trial", 1)
    max_conc = spec.get("resources", {}).get("max_concurrent")
    kinds = {r.kind for r in runs if r.scores}
    data = {
        "sweep_file": sweep_file,
        "sweep_command": sweep_cmd,
        "aggregate_command": agg_cmd,
        "sweep_time": summary.get("time"),
        "runs": [asdict(r) for r in runs],
        **result,
    }
    for entry in data["runs"]:
        entry["curve"] = entry["curve"][-1:]  # keep the page's data small
    (fig_dir / "results.json").write_text(json.dumps(data, indent=1) + "\n")
    tgt_txt = (
        ", ".join(
            f"{k} {'≥' if k in RATE_METRICS else '≤'} {v:g}" for k, v in sorted(target.items())
        )
        if target
        else "none"
    )
    src = f"sweep `{sweep_file}`, `{sweep_cmd}`, then `{agg_cmd}`"
    lines = [
        "# Benchmark",
        "",
        "<!-- Generated by `cdcr-gym aggregate` (training/sweep/aggregate.py); do not edit: "
        "rerun the sweep and the generator. -->",
        "",
        f"Every number on this page comes from the {src} "
        f"(sweep run finished {summary.get('time', '?')}; {n_ok}/{len(runs)} trials complete). "
        f"The data behind the tables: [`{rel}/results.json`]({rel}/results.json).",
        "",
        *([note, ""] if note else []),
        "## Protocol",
        "",
        "* **Budget**: per task, every algorithm trains for the same wall-clock budget "
        "(`runtime.max_wall_time_s`, the periodic evaluations during training count against "
        "it), set in each part of the sweep (table *Parts* below); an algorithm whose config "
        "reaches its `total_timesteps` first stops there. Training stops at the first env step "
        "past the budget, then evaluates the final weights once more, so the *train wall time* "
        "column exceeds the budget by that last evaluation."
        if parts
        else f"* **Budget**: every run trains for the same wall-clock budget, "
        f"**{budget:g} s of training wall time** (`runtime.max_wall_time_s`; the periodic "
        f"evaluations during training count against it), whatever the env steps it reaches. "
        f"Training stops at the first env step past the budget, then evaluates the final "
        f"weights once more, so the *train wall time* column exceeds the budget by that last "
        f"evaluation."
        if budget
        else "* **Budget**: the configs' own `total_timesteps` (no wall-clock budget set).",
        f"* **Runs**: each (task, algorithm) with seeds {sorted({r.seed for r in runs})}, as Ray "
        f"Tune trials ({concurrency} executor, {cpus:g} CPU per trial, "
        + (
            f"at most {max_conc} concurrent trial{'s' if max_conc > 1 else ''})"
            if max_conc
            else "so as many concurrent trials as cores)"
        )
        + ", each an ordinary `training.run.train` run directory.",
        f"* **Machine**: {_machine(summary, runs)}. " + machine_sharing(summary, runs, max_conc),
        "* **Scores**: after training, `cdcr-gym evaluate RUN_DIR --model best` on "
        "fixed goals (reset seeds from `evaluate.seed`, the same for every run) from each "
        "starting state (`straight_100steps`: straight start, 100 steps; `random_100steps`: a random "
        "starting shape). Per run: the median final tip error, and the fractions of goals "
        "within 5 mm and 1 mm"
        + (
            "; for Track, Pose and Obstacle the task's own metrics (`training.run.metrics`): "
            "the median over the episodes of the tracking RMS (Track, after the settling "
            "window), of the final tip direction error (Pose), the fraction of episodes with a "
            "collision (Obstacle), beside the task's oracle on the same episodes (and, for "
            "Obstacle, the plain reach IK that ignores the obstacles). **Success** is the env's "
            "`is_success` at the last step: "
            + "; ".join(f"{k}: {v}" for k, v in SUCCESS.items() if k in kinds)
            + ". The *median final error* is the final tip distance to the goal (Track: to "
            "the moving target)."
            if kinds - {"Reach"}
            else "."
        )
        + " Reference rows (in italics), on the same episodes as every run: the oracles — "
        "the analytic IK (Reach) or the task's oracle, open loop and, on a physics backend, "
        "also closed loop (corrected from the measured tip every step) — and the uniform "
        "random policy (tensions drawn uniformly from the action space: the floor).",
        f"* **Estimator**: interquartile mean across runs with a 95 % stratified-bootstrap "
        f"percentile interval ({reps:,} resamples; rliable's method, implemented in "
        f"`training/sweep/statistics.py`). " + _iqm_note(n_per_group),
        f"* **Target** (for the time-to-target columns): the first periodic evaluation during "
        f"training (`eval_log.csv`) with {tgt_txt}.",
        "",
        f"Covered by this sweep: algorithms {', '.join(sorted({r.algo for r in runs}))}; "
        f"tasks {', '.join(sorted({r.task for r in runs}))}"
        + (
            f"; run so far: {', '.join(sorted({r.task for r in ran}))}."
            if len(ran) < len(runs)
            else "."
        ),
        "",
        *(
            [
                "## Parts",
                "",
                "The sweep runs in parts (`cdcr-gym sweep SWEEP --part NAME`), at different "
                "times into one output directory; what ran where and for how long:",
                "",
                *parts_table(summary, runs),
                "",
            ]
            if parts
            else []
        ),
        "## IQM per task and algorithm",
        "",
        *iqm_table(result),
        "",
        f"![IQM and 95 % CIs]({rel}/iqm.png)",
        "",
    ]
    agg = aggregate_table(result)
    if agg:
        lines += [
            "## Across tasks",
            "",
            "IQM of the rates over every task's runs, the bootstrap stratified by task "
            "(success as each task defines it, see Protocol).",
            "",
            *agg,
            "",
        ]
    lines += [
        "## Performance profiles",
        "",
        "Fraction of runs whose median final error (Track: median tracking RMS) is at most "
        "τ, with 95 % bootstrap bands (grey lines: 1 mm and 5 mm; black dotted lines: the "
        "task's reference rows on the straight start, oracles and random policy).",
        "",
        f"![performance profiles]({rel}/performance_profiles.png)",
        "",
        "## Env steps and wall time to the target",
        "",
        *target_table(runs, target),
        "",
        f"![learning curves]({rel}/learning_curves.png)",
        "",
        "## Every run",
        "",
        *runs_table(ran, target),
        "",
    ]
    failed = [r for r in runs if r.status not in ("complete", "not run")]
    if failed:
        lines += ["## Failed trials", ""]
        for r in failed:
            tail = (r.error or "").strip().splitlines()[-3:]
            lines.append(f"* `{r.trial_id}`: {r.status}; " + " / ".join(f"`{t}`" for t in tail))
        lines.append("")
    lines += [
        "## Reproduce",
        "",
        "```bash",
        f"nice -n 5 {sweep_cmd}",
        f"{agg_cmd}",
        "```",
        "",
        "A re-run of the sweep skips the finished trials; add the configs of new algorithms or "
        "tasks to the sweep file and rerun both commands to extend the tables.",
        "",
    ]
    page.write_text("\n".join(lines))


def _iqm_note(n_per_group: list[int]) -> str:
    """What the IQM does with the number of runs per group."""
    if not n_per_group:
        return ""
    n = n_per_group[0] if len(n_per_group) == 1 else None
    if n is not None and int(0.25 * n) == 0:
        return (
            f"With {n} runs per group the IQM cuts no run (`int(0.25·{n}) = 0`): it equals the "
            f"mean, and the interval comes from resampling only {n} values, so it is wide and "
            "coarse."
        )
    sizes = " or ".join(map(str, n_per_group))
    cuts = ", ".join(f"{int(0.25 * k)} at each end of {k}" for k in n_per_group)
    return (
        f"With {sizes} runs per group the IQM drops the best and the worst runs ({cuts}) and "
        "averages the rest."
    )


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="cdcr-gym aggregate",
        description="IQM with stratified-bootstrap CIs and performance profiles of a sweep.",
    )
    parser.add_argument("sweep_dir", type=Path, metavar="SWEEP_OUT", help="a sweep's out_dir")
    parser.add_argument(
        "--doc",
        type=Path,
        default=None,
        help="write the benchmark page (e.g. docs/experiments/benchmark.md)",
    )
    parser.add_argument(
        "--reps", type=positive_int, default=50_000, help="bootstrap resamples (50 000)"
    )
    parser.add_argument("--seed", type=non_negative_int, default=0, help="bootstrap RNG seed")
    parser.add_argument(
        "--note", default=None, help="a paragraph for the page, under its introduction"
    )
    args = parser.parse_args(argv)
    if args.reps <= 0:
        print(f"error: --reps must be a positive integer, got {args.reps}", file=sys.stderr)
        return 2
    try:
        summary, runs = load_runs(args.sweep_dir)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    result = aggregate(runs, reps=args.reps, seed=args.seed)
    target = summary.get("spec", {}).get("target") or {}
    print("\n".join([*iqm_table(result), "", *target_table(runs, target)]))
    (args.sweep_dir / "aggregate.json").write_text(json.dumps(result, indent=1) + "\n")
    if args.doc is not None:
        write_doc(args.doc, args.sweep_dir, summary, runs, result, argv, args.reps, args.note)
        print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
