"""Evaluate PPO runs on the calibrated FTDCR v4 twin beside the closed-loop IK oracle.

Usage (from the repository root; configs/twin_ftdcr_v4_reach.sh runs it)::

    python configs/twin_ftdcr_v4_eval.py --config CONFIG --params PARAMS_YAML [RUN_DIR ...]
        [--oracles] [--env-id cdcr_gym/MuJoCoReach-v0] [--episodes 100] [--seed 1000000]
        [--out docs/figures/twin_ftdcr_v4] [--tag mujoco]

Every episode is built exactly as a user builds the twin::

    gym.make(env_id, params=PARAMS_YAML, **twin_kwargs_from_yaml(PARAMS_YAML, action_mode=...))

(the fit's backend arguments and its tendon drive's cap and backlash, on a physics backend; the
action mode, displacement step and success radius are the run's ``env.kwargs``). Episode
i is ``reset(seed=seed + i)``: its goal is drawn by the env's own goal sampler (in a displacement
mode, the equilibrium of a displacement command within the drives' range, so every goal is
reachable), its start is straight (first half of the episodes) or a random shape (second half).
Each policy (deterministic, with its VecNormalize statistics, from ``final_model/``) and, with
``--oracles``, the IK oracle (``cdcr_gym.controllers.AnalyticIKController.from_env(env,
feedback=...)``: closed loop, the fitted robot's model IK corrected on the measured tip; and
open loop, the model's IK solution commanded) run the registered episode length (100 steps) on
the same episodes; the final tip error is scored.

Writes ``OUT/eval_<tag>.json`` (per controller: median, p95, mean, max final tip error in mm,
success within 5 mm and within 1 mm, per starting state, overall and by the goal's height
(``by_goal_height``: goals below the robot's base, z < 0 in the measurement frame, where the tip
bends past 90°, and the others); per-episode errors; a controller already in the file from the
same episodes is kept, so the oracles and the policies can be run separately) and
``OUT/eval_<tag>.png`` (the errors' empirical distributions); ``OUT/eval_<tag>.md`` lists the
commands that evaluated its controllers. ``--table-only`` rewrites the
statistics, the Markdown table and the figure from the JSON's per-episode errors and goals
(no episodes run).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401  (registers the envs)
from cdcr_gym.calibration import twin_kwargs_from_yaml
from cdcr_gym.controllers import AnalyticIKController
from training.run.config import load_config
from training.run.rollout import SB3Policy

ENV_KEYS = ("action_mode", "displacement_step", "tension_step", "distance_threshold")


def make_twin(env_id: str, params: str, run_kwargs: dict[str, Any], initial_state: str) -> Any:
    """The twin env of ``params`` with the run's action settings and, on a physics backend,
    everything the fit simulated (``twin_kwargs_from_yaml``: backend arguments, the drives' cap
    and backlash); the analytic CCKA twin takes the action settings only."""
    kw = {k: run_kwargs[k] for k in ENV_KEYS if k in run_kwargs}
    if "CCKA" not in env_id:
        kw = {**twin_kwargs_from_yaml(params, action_mode=kw["action_mode"]), **kw}
    return gym.make(env_id, params=params, initial_state=initial_state, **kw)


def memoise_targets(ik: AnalyticIKController) -> AnalyticIKController:
    """``ik`` with its IK solution cached per goal (an episode's goal is fixed: the numerical
    IK of a 3-section robot need not be re-solved every step; the same results, faster)."""
    solve = ik.targets
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def targets(goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.ascontiguousarray(goal, dtype=np.float64).tobytes()
        if key not in cache:
            if len(cache) > 64:
                cache.clear()
            cache[key] = solve(goal)
        return cache[key]

    ik.targets = targets  # type: ignore[method-assign]
    return ik


def run_episode(env: Any, act: Any, seed: int) -> tuple[float, np.ndarray]:
    """One episode from ``reset(seed=seed)`` to truncation: (final tip error m, goal (3,) m)."""
    obs, info = env.reset(seed=seed)
    goal = np.asarray(info["goal"], dtype=float).copy()
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(act(obs))
        done = term or trunc
    return float(info["distance"]), goal


def stats(errors_m: np.ndarray) -> dict[str, float]:
    """Final-error statistics (mm) and success rates of errors (m)."""
    mm = np.asarray(errors_m) * 1000.0
    return {
        "median_mm": float(np.median(mm)),
        "p95_mm": float(np.percentile(mm, 95)),
        "mean_mm": float(np.mean(mm)),
        "max_mm": float(np.max(mm)),
        "success_5mm": float(np.mean(mm <= 5.0)),
        "within_1mm": float(np.mean(mm <= 1.0)),
        "episodes": int(mm.size),
    }


#: The goal-height groups of ``by_goal_height``: name → test on the goal's z (m).
HEIGHTS = {
    "below the base (z < 0)": lambda z: z < 0.0,
    "above the base (z >= 0)": lambda z: z >= 0.0,
}


def summarise(result: dict[str, Any]) -> None:
    """Fill every controller's statistics in ``result`` from its per-episode errors
    (``final_errors_mm``, per starting state) and the episodes' goals (``goals_m``, m): overall,
    per starting state and by the goal's height (:data:`HEIGHTS`; a group without goals is left
    out)."""
    goals = result["goals_m"]
    z = np.concatenate([np.asarray(goals[s], dtype=float).reshape(-1, 3)[:, 2] for s in goals])
    for name, r in result["controllers"].items():
        per = {s: np.asarray(v, dtype=float) * 1e-3 for s, v in r["final_errors_mm"].items()}
        if list(per) != list(goals) or any(per[s].size != len(goals[s]) for s in goals):
            raise ValueError(f"controller {name!r}: its errors do not match the episodes' goals")
        all_e = np.concatenate(list(per.values()))
        r["all"] = stats(all_e)
        r.update({s: stats(v) for s, v in per.items()})
        r["by_goal_height"] = {h: stats(all_e[f(z)]) for h, f in HEIGHTS.items() if f(z).any()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="*", type=Path)
    ap.add_argument("--config", required=True, type=Path, help="the training config (env.kwargs)")
    ap.add_argument("--params", required=True)
    ap.add_argument("--oracles", action="store_true", help="also run the IK oracles")
    ap.add_argument("--env-id", default="cdcr_gym/MuJoCoReach-v0")
    ap.add_argument("--episodes", type=int, default=100, help="per starting state")
    ap.add_argument("--seed", type=int, default=1_000_000)
    ap.add_argument("--out", type=Path, default=Path("docs/figures/twin_ftdcr_v4"))
    ap.add_argument("--tag", default="mujoco")
    ap.add_argument(
        "--table-only",
        action="store_true",
        help="rewrite OUT/eval_TAG.json's statistics, .md and .png from its episodes",
    )
    args = ap.parse_args(argv)
    if args.table_only:
        out_json = args.out / f"eval_{args.tag}.json"
        if not out_json.is_file():
            raise ValueError(f"--table-only: {out_json} not found")
        result = json.loads(out_json.read_text())
        summarise(result)
        result.setdefault("commands", _md_commands(args.out / f"eval_{args.tag}.md"))
        write(result, args.out, args.tag)
        return 0
    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    import torch

    torch.set_num_threads(1)  # tiny MLPs: one thread is fastest (and shares the machine)
    t0 = time.perf_counter()
    run_kwargs = dict(load_config(args.config).env.kwargs)
    policies = {}
    for run in args.runs:
        config = load_config(run / "config.yaml")
        model = run / "final_model"
        vn = model / "vecnormalize.pkl"
        pol = SB3Policy(model / "model.zip", vn if vn.exists() else None, algo=config.algo)
        policies[f"{run.name} (seed {config.seed})"] = pol
    errors: dict[str, dict[str, list[float]]] = {}
    goals: dict[str, list[list[float]]] = {}
    for state in ("straight", "random"):
        env = make_twin(args.env_id, args.params, run_kwargs, state)
        controllers = dict(policies)
        if args.oracles:
            for name, fb in (("closed-loop IK", True), ("open-loop IK", False)):
                ik = memoise_targets(AnalyticIKController.from_env(env, feedback=fb))
                controllers[name] = lambda o, c=ik: c.action(o)
        goals[state] = []
        for i in range(args.episodes):
            seed = args.seed + i
            goal = None
            for name, pol in controllers.items():
                e, g = run_episode(env, lambda o, p=pol: p(o[None])[0], seed)
                if goal is None:
                    goal = g
                    goals[state].append(goal.tolist())
                elif not np.allclose(g, goal, rtol=0.0, atol=1e-12):
                    raise RuntimeError(f"episode seed {seed}: the goal differs between runs")
                errors.setdefault(name, {}).setdefault(state, []).append(e)
            print(f"{state} {i + 1}/{args.episodes}", flush=True)
        env.close()
    result: dict[str, Any] = {
        "env_id": args.env_id,
        "params": args.params,
        "env_kwargs": {k: run_kwargs[k] for k in ENV_KEYS if k in run_kwargs},
        "episodes_per_start": args.episodes,
        "seed": args.seed,
        "controllers": {},
        "goals_m": goals,
        "commands": [],
    }
    out_json = args.out / f"eval_{args.tag}.json"
    if out_json.exists():  # keep the controllers evaluated before on the same episodes
        old = json.loads(out_json.read_text())
        same = all(old.get(k) == result[k] for k in ("env_id", "params", "env_kwargs", "seed"))
        same = same and old.get("episodes_per_start") == args.episodes
        if same and np.allclose(
            np.asarray(old["goals_m"]["straight"]), np.asarray(goals["straight"]), atol=1e-9
        ):
            result["controllers"].update(
                {k: v for k, v in old["controllers"].items() if k not in errors}
            )
            result["commands"] = old.get("commands", _md_commands(out_json.with_suffix(".md")))
    result["seconds"] = time.perf_counter() - t0
    for name, per in errors.items():
        result["controllers"][name] = {
            "final_errors_mm": {s: [round(x * 1000.0, 4) for x in v] for s, v in per.items()}
        }
    summarise(result)
    result["commands"].append(
        "python configs/twin_ftdcr_v4_eval.py " + " ".join(argv or sys.argv[1:])
    )
    write(result, args.out, args.tag)
    return 0


def _md_commands(md: Path) -> list[str]:
    """The commands recorded in an ``eval_TAG.md`` written before the JSON kept them (none if
    there is no such file)."""
    if not md.is_file():
        return []
    prefix = "python configs/twin_ftdcr_v4_eval.py"
    return [line for line in md.read_text().splitlines() if line.startswith(prefix)]


def write(result: dict[str, Any], out: Path, tag: str) -> None:
    """``OUT/eval_TAG.json``, ``.png`` and ``.md`` (with the JSON's ``commands``), and a summary
    printed."""
    out.mkdir(parents=True, exist_ok=True)
    (out / f"eval_{tag}.json").write_text(json.dumps(result, indent=1) + "\n")
    _plot(result, out / f"eval_{tag}.png")
    (out / f"eval_{tag}.md").write_text(markdown(result, result.get("commands", [])))
    for name, r in result["controllers"].items():
        a = r["all"]
        print(
            f"{name:32s} median {a['median_mm']:.3f} mm  p95 {a['p95_mm']:.3f} mm  "
            f"<=5 mm {a['success_5mm']:.1%}  <=1 mm {a['within_1mm']:.1%}"
        )


def markdown(result: dict[str, Any], commands: list[str] | None = None) -> str:
    """The result as a Markdown table (after the ``commands`` that produced it): per
    controller, all episodes, per starting state and by the goal's height."""
    n = result["episodes_per_start"]
    out = [
        f"# FTDCR v4 twin: {result['env_id']}",
        "",
        f"Robot `{result['params']}`, {result['env_kwargs']}; {n} goals per starting state "
        f"(reset seeds {result['seed']}…{result['seed'] + n - 1}), 100 steps; final tip error.",
        "",
    ]
    if commands:
        out += ["```", *commands, "```", ""]
    out += [
        "| controller | start | median (mm) | p95 (mm) | mean (mm) | max (mm) | ≤ 5 mm | ≤ 1 mm |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, r in result["controllers"].items():
        parts = {p: r[p] for p in ("all", "straight", "random")}
        parts.update({f"goal {h}": a for h, a in r.get("by_goal_height", {}).items()})
        for part, a in parts.items():
            out.append(
                f"| {name} | {part} | {a['median_mm']:.3f} | {a['p95_mm']:.3f} | "
                f"{a['mean_mm']:.3f} | {a['max_mm']:.3f} | {a['success_5mm']:.0%} | "
                f"{a['within_1mm']:.0%} |"
            )
    if any("by_goal_height" in r for r in result["controllers"].values()):
        z = np.concatenate(
            [np.asarray(g, dtype=float).reshape(-1, 3)[:, 2] for g in result["goals_m"].values()]
        )
        out += ["", f"Goals below the base: {int((z < 0).sum())} of {z.size}."]
    return "\n".join(out) + "\n"


def _plot(result: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, r in result["controllers"].items():
        e = np.sort(np.concatenate(list(r["final_errors_mm"].values())))
        ax.step(e, np.arange(1, e.size + 1) / e.size, where="post", label=name)
    ax.set_xscale("log")
    ax.set_xlabel("final tip error (mm)")
    ax.set_ylabel("fraction of episodes")
    ax.axvline(0.5, color="grey", ls=":", lw=1)
    ax.set_title(f"FTDCR v4 twin, {result['env_id'].split('/')[-1]}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
