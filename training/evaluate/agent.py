"""Evaluate a trained run against the analytic-IK oracle, on fixed-seed goals.

Usage::

    python -m training.evaluate RUN_DIR [--episodes N] [--env-id ID] [--video]
                                [--model best|final] [--env-kwarg KEY=VALUE ...] [--tag NAME]

Loads the run's best model (``best_model/``; ``final_model/`` with ``--model final`` or the
config's ``evaluate.model: final``) with its VecNormalize
statistics, and runs, for every starting state × horizon of the config's ``evaluate`` section
(default: straight and random starting shapes × 100 and 200 steps), N episodes on goals and
starting shapes drawn with reset seeds ``evaluate.seed + i`` — the same for every run, model and
backend. The analytic-IK controller (``cdcr_gym.controllers.AnalyticIKController``) runs on
exactly the same goals and starts, in the same backend and for the same number of steps.

Writes ``RUN_DIR/eval.json`` (``RUN_DIR/eval_<tag>.json`` for another env id or env kwargs) and
figures in ``RUN_DIR/eval/`` (``eval_<tag>/``), and prints a table. The JSON's top-level
``success_rate``, ``within_1mm``, ``error_mm`` and ``ik`` are the *headline* condition (the first
starting state and the first horizon, by default: straight start, the training episode length);
``conditions`` holds every condition in the same layout:

* ``success_rate``: fraction of episodes whose *final* tip error is within the env's
  ``distance_threshold`` (5 mm by default); ``within_1mm`` likewise at 1 mm;
* ``error_mm``: ``mean``, ``median``, ``p95``, ``max`` of the final tip error (mm);
* ``max_error_after_train_horizon_mm`` (horizons longer than the training episode): per episode,
  the largest error from the training episode length to the end — does the agent hold the goal;
* ``ik``: the IK controller's ``success_rate``, ``within_1mm``, ``error_mm``, and the distance
  between the policy's final cable state and the IK solution for the goal —
  ``cable_length_distance_mm`` (Euclidean over the three cables, mm), ``tension_distance_n``
  (N) and ``tension_distance_bending_n`` (N, after removing each side's common-mode tension,
  min_i T_i, which does not bend the CCKA robot).

``--env-id`` evaluates the policy on another backend (sim-to-sim, e.g. a CCKA-trained tension
policy on ``cdcr_gym/BulletReach-v0``); the IK runs on that backend too. ``--video`` writes an
an H.264 MP4 (``training.evaluate.video``, ffmpeg from imageio-ffmpeg) of the first few headline episodes.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym.controllers import AnalyticIKController
from training.evaluate import plots, tables
from training.evaluate.conditions import condition_name
from training.evaluate.oracles import plot_paths
from training.evaluate.overlay import caption, draw_text
from training.evaluate.random_policy import RandomPolicy
from training.evaluate.video import write_video
from training.run.argtypes import non_negative_int, positive_int
from training.run.config import (
    EVALUATE_MODELS,
    ConfigError,
    ExperimentConfig,
    check_writable_directory,
    load_config,
)
from training.run.envs import registered_steps
from training.run.metrics import (
    error_stats,
    is_physics,
    oracle_for,
    run_task_episodes,
    summarize,
    summarize_task,
    task_name,
)
from training.run.rollout import (
    ModelFileError,
    SB3Policy,
    check_env_id,
    make_env,
    make_specs,
    parse_env_kwarg,
    run_episodes,
)

__all__ = ["main", "evaluate"]


def _tag_for(env_id: str, overrides: dict[str, Any]) -> str:
    name = env_id.split("/")[-1]
    parts = [name] + [f"{k}-{v}" for k, v in sorted(overrides.items())]
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", "_".join(parts))


def _state_distances(
    tensions: np.ndarray, lengths: np.ndarray, ik_tensions: np.ndarray, ik_lengths: np.ndarray
) -> dict[str, dict[str, float]]:

    dl = np.linalg.norm(lengths - ik_lengths, axis=-1)
    dt = np.linalg.norm(tensions - ik_tensions, axis=-1)
    bend = tensions - tensions.min(axis=-1, keepdims=True)
    ik_bend = ik_tensions - ik_tensions.min(axis=-1, keepdims=True)
    db = np.linalg.norm(bend - ik_bend, axis=-1)
    return {
        "cable_length_distance_mm": error_stats(dl, 1000.0),
        "tension_distance_n": error_stats(dt),
        "tension_distance_bending_n": error_stats(db),
    }


def evaluate(
    run_dir: Path,
    config: ExperimentConfig,
    *,
    episodes: int,
    env_id: str,
    env_kwargs: dict[str, Any],
    model: str = "best",
    tag: str | None = None,
    video: bool = False,
    seed: int | None = None,
    command: str = "",
) -> dict[str, Any]:
    """Run the evaluation, write JSON + figures, return the result dict."""
    import torch

    torch.set_num_threads(config.runtime.torch_threads)
    t0 = time.perf_counter()
    model_dir = run_dir / ("best_model" if model == "best" else "final_model")
    vn_path = model_dir / "vecnormalize.pkl"
    policy = SB3Policy(
        model_dir / "model.zip", vn_path if vn_path.exists() else None, algo=config.algo
    )
    model_info: dict[str, Any] = {}
    if (model_dir / "info.json").exists():
        model_info = json.loads((model_dir / "info.json").read_text())
    model_step = model_info.get("timesteps", int(policy.model.num_timesteps))

    ev = config.evaluate
    seed = ev.seed if seed is None else seed
    train_horizon = config.env.max_episode_steps or registered_steps(config.env.id)
    probe = make_env(env_id, env_kwargs)
    if type(probe.unwrapped.task).__name__ != "Reach":
        probe.close()
        return _evaluate_task(
            run_dir, config, policy, episodes, env_id, env_kwargs, tag, seed, model_step, command
        )
    params = probe.unwrapped.params
    threshold = float(probe.unwrapped.task.distance_threshold)
    ik = AnalyticIKController.from_env(probe)

    # on a physics backend the open-loop IK misses by centimetres: the closed-loop IK beside it
    closed = AnalyticIKController.from_env(probe, feedback=True) if is_physics(probe) else None
    action_space = probe.action_space
    probe.close()

    out_json = run_dir / ("eval.json" if tag is None else f"eval_{tag}.json")
    fig_dir = run_dir / ("eval" if tag is None else f"eval_{tag}")
    fig_dir.mkdir(parents=True, exist_ok=True)

    conditions: dict[str, Any] = {}
    raw: dict[str, Any] = {}
    for initial_state in ev.initial_states:
        specs = make_specs(episodes, seed, initial_state, params)
        ik_tensions, ik_lengths = ik.targets(specs.goals)
        for horizon in ev.horizons:
            name = condition_name(initial_state, horizon)

            def env_fn(h: int = horizon) -> Any:
                return make_env(env_id, env_kwargs, max(h, train_horizon))

            pol = run_episodes(env_fn, policy, specs, horizon)
            ikr = run_episodes(env_fn, ik.action, specs, horizon)
            cond: dict[str, Any] = {"initial_state": initial_state, "horizon": horizon}
            cond.update(summarize(pol.final_distance, threshold))
            cond["mean_return"] = float(np.mean(pol.returns))
            if horizon > train_horizon:
                at = pol.distances[:, train_horizon]
                cond["error_mm_at_train_horizon"] = error_stats(at, 1000.0)
                cond["max_error_after_train_horizon_mm"] = error_stats(
                    pol.distances[:, train_horizon:].max(axis=1), 1000.0
                )
            ik_block = summarize(ikr.final_distance, threshold)
            ik_block.update(
                _state_distances(pol.final_tensions, pol.final_lengths, ik_tensions, ik_lengths)
            )
            cond["ik"] = ik_block
            if closed is not None:
                closed_run = run_episodes(env_fn, closed.action, specs, horizon)
                cond["ik_closed_loop"] = summarize(closed_run.final_distance, threshold)
            # the floor: uniform random tensions on the same goals (the same draws every run)
            random_run = run_episodes(env_fn, RandomPolicy(action_space, seed), specs, horizon)
            cond["random"] = summarize(random_run.final_distance, threshold)
            conditions[name] = cond
            raw[name] = (specs, pol, ikr)

    headline = condition_name(ev.initial_states[0], ev.horizons[0])
    head = conditions[headline]
    result: dict[str, Any] = {
        "run_dir": str(run_dir),
        "model": str(model_dir / "model.zip"),
        "model_step": model_step,
        "trained_on": {"env_id": config.env.id, "env_kwargs": config.env.kwargs},
        "env_id": env_id,
        "env_kwargs": {
            k: (v if isinstance(v, (int, float, str, bool, type(None), list, dict)) else repr(v))
            for k, v in env_kwargs.items()
        },
        "episodes": episodes,
        "seed": seed,
        "distance_threshold_m": threshold,
        "train_horizon": train_horizon,
        "headline_condition": headline,
        "success_rate": head["success_rate"],
        "within_1mm": head["within_1mm"],
        "error_mm": head["error_mm"],
        "ik": head["ik"],
        **({"ik_closed_loop": head["ik_closed_loop"]} if closed is not None else {}),
        "random": head["random"],
        "conditions": conditions,
        "command": command,
    }

    # -- figures ------------------------------------------------------------------------------
    specs, pol, ikr = raw[headline]
    pol_mm, ik_mm = pol.final_distance * 1000.0, ikr.final_distance * 1000.0
    where = f"{env_id.split('/')[-1]}, {headline}"
    figures = {
        "histogram": plots.plot_error_histogram(
            {f"{config.algo.upper()} policy": pol_mm, "analytic IK": ik_mm},
            fig_dir / "error_histogram.png",
            f"final tip error ({where}, {episodes} goals)",
        ),
        "workspace": plots.plot_workspace_errors(
            specs.goals,
            pol_mm,
            fig_dir / "workspace_errors.png",
            f"PPO final error over the workspace ({where})",
        ),
        "policy_vs_ik": plots.plot_policy_vs_ik(
            pol_mm, ik_mm, fig_dir / "policy_vs_ik.png", f"per goal ({where})"
        ),
    }
    longest = max(ev.horizons)
    curves = {}
    for s in ev.initial_states:
        _, p_, i_ = raw[condition_name(s, longest)]
        curves[f"PPO ({s})"] = p_.distances
        curves[f"IK ({s})"] = i_.distances
    figures["error_vs_step"] = plots.plot_error_vs_step(
        curves,
        fig_dir / "error_vs_step.png",
        train_horizon,
        f"tip error vs step ({env_id.split('/')[-1]}, {episodes} goals)",
    )
    if video:
        figures["video"] = _write_video(
            env_id,
            env_kwargs,
            policy,
            specs,
            ev.horizons[0],
            ev.video_episodes,
            fig_dir,
            train_horizon,
        )
    result["figures"] = {k: str(v) for k, v in figures.items()}
    result["wall_time_s"] = round(time.perf_counter() - t0, 1)
    out_json.write_text(json.dumps(result, indent=2) + "\n")
    result["_json_path"] = str(out_json)
    return result


def _evaluate_task(
    run_dir: Path,
    config: ExperimentConfig,
    policy: Any,
    episodes: int,
    env_id: str,
    env_kwargs: dict[str, Any],
    tag: str | None,
    seed: int,
    model_step: int,
    command: str,
) -> dict[str, Any]:
    """Track, Pose, Obstacle: the task's own metrics for the policy beside its oracle's (and, for
    Obstacle, the plain reach IK's) on the same episodes, per starting state, at the first
    horizon (``training.run.metrics``). Writes the JSON and the path figures."""

    ev = config.evaluate
    horizon = ev.horizons[0]
    out_json = run_dir / ("eval.json" if tag is None else f"eval_{tag}.json")
    fig_dir = run_dir / ("eval" if tag is None else f"eval_{tag}")
    fig_dir.mkdir(parents=True, exist_ok=True)
    conditions: dict[str, Any] = {}
    task = ""
    for initial_state in ev.initial_states:
        kwargs = {**env_kwargs, "initial_state": initial_state}

        def env_fn(k: dict[str, Any] = kwargs) -> Any:
            return make_env(env_id, k, horizon)

        probe = env_fn()
        baselines = {"oracle": oracle_for(probe)}
        if is_physics(probe):  # the open-loop oracle misses on physics: also closed loop
            baselines["oracle_closed_loop"] = oracle_for(probe, "closed_loop")
        task = type(probe.unwrapped.task).__name__
        if task == "Obstacle":
            baselines["reach_ik"] = oracle_for(probe, "reach_ik")
        baselines["random"] = RandomPolicy.from_env(probe, seed)  # the floor
        probe.close()
        record = min(3, episodes)
        runs = {"policy": run_task_episodes(env_fn, policy, episodes, seed, record=record)}
        for name, baseline in baselines.items():
            runs[name] = run_task_episodes(env_fn, baseline, episodes, seed, record=record)
        name = condition_name(initial_state, horizon)
        conditions[name] = {key: summarize_task(value) for key, value in runs.items()}
        plot_paths(task, {k: v["paths"] for k, v in runs.items()}, fig_dir / f"{name}_paths.png")
    headline = conditions[next(iter(conditions))]
    result = {
        "run_dir": str(run_dir),
        "env_id": env_id,
        "task": task,
        "env_kwargs": env_kwargs,
        "episodes": episodes,
        "seed": seed,
        "model_step": model_step,
        "command": command,
        **headline,
        "conditions": conditions,
    }
    out_json.write_text(json.dumps(result, indent=2, default=str) + "\n")
    return result


def _write_video(
    env_id: str,
    env_kwargs: dict[str, Any],
    policy: Any,
    specs: Any,
    horizon: int,
    n_episodes: int,
    fig_dir: Path,
    train_horizon: int,
) -> Path:
    """H.264 MP4 (``training.evaluate.video``) of the first ``n_episodes`` headline episodes;
    every frame carries the step, the tip error (mm) and the task's metric
    (``training.evaluate.overlay``)."""

    kwargs = {**env_kwargs, "render_width": 320, "render_height": 320}
    env = make_env(env_id, kwargs, max(horizon, train_horizon), render_mode="rgb_array")
    frames = []
    try:
        for i in range(min(n_episodes, len(specs))):
            obs, info = env.reset(
                options={"goal": specs.goals[i], "initial_tensions": specs.initial_tensions[i]}
            )
            task = task_name(env)
            frames.append(draw_text(env.render(), caption(0, horizon, info, task)))
            for t in range(horizon):
                action = policy(obs[None])[0]
                obs, _, terminated, truncated, info = env.step(action)
                if t % 2 == 1 or terminated:
                    frames.append(draw_text(env.render(), caption(t + 1, horizon, info, task)))
                if terminated or truncated:
                    break
    finally:
        env.close()

    return write_video(fig_dir / "episodes.mp4", frames, fps=25)


def reach_columns(result: dict[str, Any]) -> list[tables.Column]:
    """The columns of the Reach table: rows are ``(condition name, condition dict)``."""
    thr = f"{result['distance_threshold_m'] * 1000.0:g}"
    headline = result["headline_condition"]
    C = tables.Column

    def err(who: str, stat: str) -> Any:
        return lambda r: f"{_block(r[1], who)['error_mm'][stat]:.3f}" if _block(r[1], who) else "–"

    def rate(who: str, key: str = "success_rate") -> Any:
        return lambda r: tables.pct(_block(r[1], who)[key]) if _block(r[1], who) else "–"

    cols = [
        C(
            "condition",
            "starting shape and episode length (* the headline)",
            lambda r: r[0] + (" *" if r[0] == headline else ""),
        ),
        C(
            f"≤{thr}mm",
            f"the policy's episodes with a final tip error ≤ {thr} mm (success)",
            rate("policy"),
        ),
        C("≤1mm", "... ≤ 1 mm", rate("policy", "within_1mm")),
        C("mean", "mean final tip error, mm", err("policy", "mean"), narrow=False),
        C("median", "median final tip error, mm", err("policy", "median")),
        C("p95", "95th percentile of the final tip error, mm", err("policy", "p95")),
        C("max", "largest final tip error, mm", err("policy", "max"), narrow=False),
        C(
            f"IK≤{thr}mm",
            "success of the analytic IK (open loop) on the same goals and starts",
            rate("ik"),
        ),
        C("IK med", "its median final tip error, mm", err("ik", "median")),
        C("IK p95", "its 95th percentile, mm", err("ik", "p95"), narrow=False),
        C(
            "ΔL IK",
            "median distance of the policy's final cable lengths from the IK solution "
            "(Euclidean over the cables), mm",
            lambda r: f"{r[1]['ik']['cable_length_distance_mm']['median']:.3f}",
            narrow=False,
        ),
        C(
            "ΔT IK",
            "median distance of the policy's final tensions from the IK solution "
            "(Euclidean over the cables), N",
            lambda r: f"{r[1]['ik']['tension_distance_n']['median']:.2f}",
            narrow=False,
        ),
    ]
    if "ik_closed_loop" in result:
        cols += [
            C(
                f"CL≤{thr}mm",
                "success of the closed-loop IK (corrected from the measured tip)",
                rate("ik_closed_loop"),
                narrow=False,
            ),
            C(
                "CL med",
                "the closed-loop IK's median final tip error, mm",
                err("ik_closed_loop", "median"),
            ),
        ]
    cols += [
        C(
            f"rnd≤{thr}mm",
            "success of uniform random tensions (the floor)",
            rate("random"),
            narrow=False,
        ),
        C(
            "rnd med",
            "median final tip error of uniform random tensions, mm",
            err("random", "median"),
        ),
    ]
    return cols


def _block(cond: dict[str, Any], who: str) -> dict[str, Any] | None:
    """The summary of ``who`` (policy, ik, ik_closed_loop, random) in one condition (None if
    absent: random is missing in eval.json files written before it was added)."""
    return cond if who == "policy" else cond.get(who)


def _print_table(result: dict[str, Any], wide: bool = False) -> None:
    columns = reach_columns(result)
    print(
        tables.wrap(
            f"{result['env_id']}: {result['episodes']} goals per condition, model at step "
            f"{result['model_step']}; every policy on the same goals and starts"
        )
    )
    print(tables.text_table(columns, list(result["conditions"].items()), wide))
    print(tables.legend(columns, wide))
    print(
        tables.wrap(
            f"wrote {result['_json_path']} and figures "
            f"{', '.join(Path(p).name for p in result['figures'].values())}"
        )
    )


def check_spaces(
    model: Any, obs_space: Any, action_space: Any, env_id: str, overrides: dict
) -> None:
    """Raise :class:`ConfigError` unless the env's observation and action spaces are the ones the
    model was trained on (e.g. ``robot=tdcr2``, six cables, for a policy of the 3-cable robot)."""
    what = f"--env-id/--env-kwarg ({env_id}" + "".join(f", {k}={v}" for k, v in overrides.items())
    for name, trained, here in (
        ("observation", model.observation_space, obs_space),
        ("action", model.action_space, action_space),
    ):
        if trained != here:
            raise ConfigError(
                f"{what}): the env's {name} space {here} is not the one the model was trained "
                f"on, {trained}; a policy only runs on envs with its spaces (same robot: "
                f"number of cables and sections, same task and observation fields)"
            )


def _parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="cdcr-gym evaluate",
        description="Evaluate a trained run (best model) against the analytic IK.",
    )
    parser.add_argument("run_dir", type=Path, metavar="RUN_DIR", help="a training run directory")
    parser.add_argument(
        "--episodes",
        type=positive_int,
        default=None,
        help="episodes per condition (default: the config's evaluate.episodes)",
    )
    parser.add_argument(
        "--env-id",
        default=None,
        help="evaluate on another registered env (default: the training env)",
    )
    parser.add_argument(
        "--env-kwarg",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override an env kwarg (YAML value), e.g. gravity=false; repeatable",
    )
    parser.add_argument("--video", action="store_true", help="write an H.264 MP4 of a few episodes")
    parser.add_argument(
        "--wide",
        action="store_true",
        help="print every column (default: the table fits 100 characters; a legend under it "
        "explains each column)",
    )
    parser.add_argument(
        "--model",
        choices=EVALUATE_MODELS,
        default=None,
        help="which saved model to evaluate (default: the config's evaluate.model, normally best)",
    )
    parser.add_argument(
        "--seed",
        type=non_negative_int,
        default=None,
        help="first reset seed of the goals (default: the config's evaluate.seed)",
    )
    parser.add_argument(
        "--tag",
        default=None,
        help="output name: eval_<tag>.json (default: eval.json on the training "
        "env, else derived from --env-id / --env-kwarg)",
    )
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    args = _parse_args(argv)
    try:
        run_dir: Path = args.run_dir
        if not run_dir.is_dir():
            raise ConfigError(f"RUN_DIR {str(run_dir)!r} is not a directory")
        if not (run_dir / "config.yaml").is_file():
            raise ConfigError(f"RUN_DIR {str(run_dir)!r} is not a training run (no config.yaml)")
        check_writable_directory(run_dir, "RUN_DIR")
        config = load_config(run_dir / "config.yaml")
        if args.model is None:  # the config's choice (evaluate.model), normally best
            args.model = config.evaluate.model
        model_dir = run_dir / ("best_model" if args.model == "best" else "final_model")
        if not (model_dir / "model.zip").is_file():
            raise ConfigError(
                f"--model {args.model}: {model_dir / 'model.zip'} does not exist "
                f"(has the run evaluated/finished yet?)"
            )
        if args.episodes is not None and args.episodes <= 0:
            raise ConfigError(f"--episodes must be a positive integer, got {args.episodes}")
        if args.seed is not None and args.seed < 0:
            raise ConfigError(f"--seed must be >= 0, got {args.seed}")
        if args.tag is not None and not re.fullmatch(r"[A-Za-z0-9_.-]+", args.tag):
            raise ConfigError(f"--tag must be a simple file-name part, got {args.tag!r}")

        env_id = args.env_id or config.env.id
        try:
            check_env_id(env_id, "--env-id")
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        try:
            overrides = dict(parse_env_kwarg(t) for t in args.env_kwarg)
        except ValueError as exc:
            raise ConfigError(str(exc)) from None
        env_kwargs = {**config.env.kwargs, **overrides}
        tag = args.tag
        if tag is None and (env_id != config.env.id or overrides):
            tag = _tag_for(env_id, overrides)
        try:
            probe = make_env(env_id, env_kwargs)
            spaces = (probe.observation_space, probe.action_space)
            probe.close()
        except (ValueError, TypeError) as exc:
            raise ConfigError(
                f"--env-id/--env-kwarg: cannot make {env_id!r} with {env_kwargs}: {exc}"
            ) from None

        vn_path = model_dir / "vecnormalize.pkl"
        try:  # a truncated model or a corrupt VecNormalize: a clear error, before any output
            policy = SB3Policy(
                model_dir / "model.zip", vn_path if vn_path.exists() else None, algo=config.algo
            )
        except ModelFileError as exc:
            raise ConfigError(str(exc)) from None
        check_spaces(policy.model, *spaces, env_id, overrides)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    command = " ".join(shlex.quote(a) for a in ["cdcr-gym", "evaluate", *argv])
    result = evaluate(
        run_dir,
        config,
        episodes=args.episodes or config.evaluate.episodes,
        env_id=env_id,
        env_kwargs=env_kwargs,
        model=args.model,
        tag=tag,
        video=args.video,
        seed=args.seed,
        command=command,
    )
    if "task" in result:
        _print_task_table(result, args.wide)
    else:
        _print_table(result, args.wide)
    return 0


def _print_task_table(result: dict[str, Any], wide: bool = False) -> None:
    """One row per condition and policy: success, error and the task's own numbers."""
    print(f"{result['task']} on {result['env_id']}: {result['episodes']} episodes per condition")
    rows = [
        (name, who, s) for name, block in result["conditions"].items() for who, s in block.items()
    ]
    columns = tables.task_columns(result["task"])
    print(tables.text_table(columns, rows, wide))
    print(tables.legend(columns, wide))


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
