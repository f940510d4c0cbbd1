"""Evaluate a trained run beside its task's oracle and baselines, on fixed-seed episodes.

Usage::

    python -m training.evaluate RUN_DIR [--episodes N] [--env-id ID] [--video]
                                [--model best|final] [--env-kwarg KEY=VALUE ...] [--tag NAME]

One pipeline for every task (Reach, Track, Pose, Obstacle). Loads the run's best model
(``best_model/``; ``final_model/`` with ``--model final`` or the config's ``evaluate.model:
final``) with its VecNormalize statistics, and runs, for every starting state × horizon of the
config's ``evaluate`` section (default: straight and random starting shapes × 100 and 200
steps), N episodes reset with seeds ``evaluate.seed + i`` — the same for every run, model and
backend — by :func:`training.run.rollout.run_episodes`. On exactly the same episodes run the
baselines (:func:`baselines`): the task's oracle (``cdcr_gym.controllers.oracle_for``), on a
physics backend also closed loop, for a task with obstacles the plain reach IK, and uniform
random actions (the floor).

Writes ``RUN_DIR/eval.json`` (``RUN_DIR/eval_<tag>.json`` for another env id or env kwargs) and
figures in ``RUN_DIR/eval/`` (``eval_<tag>/``), and prints a table. The JSON (one shape for every
task): the run and env, ``task``, ``episodes``, ``seed``, ``train_horizon``,
``headline_condition`` (the first starting state at the first horizon: by default straight start,
the training episode length), ``conditions`` (``straight_100steps``, ...: ``initial_state``,
``horizon`` and one summary per policy — ``policy``, ``oracle``, ``oracle_closed_loop``,
``reach_ik``, ``random``), the headline condition's summaries again at the top level, the
``command``, ``figures`` and ``wall_time_s``. A summary is :func:`training.run.metrics.summarize`:
success rate, final distance statistics (mm), the task's own metrics, and for the policy
``to_oracle``, the distance of its final cable state from the oracle's on the same episode.

``--env-id`` evaluates the policy on another backend (sim-to-sim, e.g. a CCKA-trained tension
policy on ``cdcr_gym/BulletReach-v0``); the baselines run on that backend too. ``--video`` writes
an H.264 MP4 (``training.evaluate.video``, ffmpeg from imageio-ffmpeg) of the first few headline
episodes.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import cdcr_gym  # noqa: F401
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
from training.run.metrics import is_physics, oracle_for, summarize, task_name
from training.run.rollout import (
    EpisodeSpecs,
    ModelFileError,
    Rollouts,
    SB3Policy,
    check_env_id,
    make_env,
    parse_env_kwarg,
    run_episodes,
)

__all__ = ["main", "evaluate", "evaluate_policies", "baselines", "print_table", "check_spaces"]

#: episodes whose paths are drawn per condition (Track: target vs tip; Obstacle: the scene)
PATH_EPISODES = 3


def _tag_for(env_id: str, overrides: dict[str, Any]) -> str:
    name = env_id.split("/")[-1]
    parts = [name] + [f"{k}-{v}" for k, v in sorted(overrides.items())]
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", "_".join(parts))


def baselines(env: Any, seed: int) -> dict[str, Any]:
    """The policies every evaluation runs beside the trained one, on the same episodes, built
    from ``env``: ``oracle`` (the task's, open loop), ``oracle_closed_loop`` (physics backends
    only: the open-loop oracle misses there), ``reach_ik`` (a task whose env reports
    collisions: the plain reach IK, which ignores the obstacles) and ``random`` (uniform random
    actions drawn from ``seed``: the floor)."""
    out = {"oracle": oracle_for(env)}
    if is_physics(env):
        out["oracle_closed_loop"] = oracle_for(env, "closed_loop")
    if "collision" in env.unwrapped.task.info_keys():
        out["reach_ik"] = oracle_for(env, "reach_ik")
    out["random"] = RandomPolicy.from_env(env, seed)
    return out


def evaluate_policies(
    env_id: str,
    env_kwargs: dict[str, Any],
    policy: Callable[[Any], np.ndarray],
    *,
    initial_states: list[str],
    horizons: list[int],
    episodes: int,
    seed: int,
    train_horizon: int,
    record: int = 0,
) -> tuple[str, dict[str, Any], dict[str, dict[str, Rollouts]]]:
    """Run ``policy`` and the :func:`baselines` on the same episodes in every condition.

    Every condition (starting state × horizon) runs ``episodes`` episodes reset with seeds
    ``seed + i`` in ``make_env(env_id, {**env_kwargs, "initial_state": state},
    max(horizon, train_horizon))`` for ``horizon`` steps.

    Returns:
        ``(task, conditions, rollouts)``: the task's name; per condition name its
        ``initial_state``, ``horizon`` and one :func:`training.run.metrics.summarize` per
        policy (``policy`` first); the same conditions' :class:`Rollouts` per policy.
    """
    conditions: dict[str, Any] = {}
    raw: dict[str, dict[str, Rollouts]] = {}
    task = ""
    specs = EpisodeSpecs.from_seeds(episodes, seed)
    for initial_state in initial_states:
        kwargs = {**env_kwargs, "initial_state": initial_state}
        for horizon in horizons:

            def env_fn(k: dict[str, Any] = kwargs, h: int = horizon) -> Any:
                return make_env(env_id, k, max(h, train_horizon))

            probe = env_fn()
            task = task_name(probe)
            policies = {"policy": policy, **baselines(probe, seed)}
            probe.close()
            runs = {
                who: run_episodes(env_fn, act, specs, horizon, record=record)
                for who, act in policies.items()
            }
            cond: dict[str, Any] = {"initial_state": initial_state, "horizon": horizon}
            for who, rollouts in runs.items():
                reference = runs["oracle"] if who == "policy" else None
                cond[who] = summarize(task, rollouts, train_horizon, reference)
            name = condition_name(initial_state, horizon)
            conditions[name] = cond
            raw[name] = runs
    return task, conditions, raw


def _jsonable(kwargs: dict[str, Any]) -> dict[str, Any]:
    plain = (int, float, str, bool, type(None), list, dict)
    return {k: (v if isinstance(v, plain) else repr(v)) for k, v in kwargs.items()}


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
    """Run the evaluation of ``run_dir``'s model, write JSON + figures, return the result dict
    (the JSON's content and ``_json_path``)."""
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
    probe: Any = make_env(env_id, env_kwargs)
    threshold = getattr(probe.unwrapped.task, "distance_threshold", None)
    probe.close()
    task, conditions, raw = evaluate_policies(
        env_id,
        env_kwargs,
        policy,
        initial_states=list(ev.initial_states),
        horizons=list(ev.horizons),
        episodes=episodes,
        seed=seed,
        train_horizon=train_horizon,
        record=min(PATH_EPISODES, episodes),
    )
    out_json = run_dir / ("eval.json" if tag is None else f"eval_{tag}.json")
    fig_dir = run_dir / ("eval" if tag is None else f"eval_{tag}")
    fig_dir.mkdir(parents=True, exist_ok=True)
    headline = condition_name(ev.initial_states[0], ev.horizons[0])
    head = conditions[headline]
    result: dict[str, Any] = {
        "run_dir": str(run_dir),
        "model": str(model_dir / "model.zip"),
        "model_step": model_step,
        "trained_on": {"env_id": config.env.id, "env_kwargs": _jsonable(config.env.kwargs)},
        "env_id": env_id,
        "env_kwargs": _jsonable(env_kwargs),
        "task": task,
        "episodes": episodes,
        "seed": seed,
        "distance_threshold_m": None if threshold is None else float(threshold),
        "train_horizon": train_horizon,
        "headline_condition": headline,
        **{who: s for who, s in head.items() if who not in ("initial_state", "horizon")},
        "conditions": conditions,
        "command": command,
    }
    figures = _figures(result, raw, fig_dir, config.algo.upper(), list(ev.horizons))
    if video:
        figures["video"] = _write_video(
            env_id,
            {**env_kwargs, "initial_state": ev.initial_states[0]},
            policy,
            EpisodeSpecs.from_seeds(episodes, seed),
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


def _figures(
    result: dict[str, Any],
    raw: dict[str, dict[str, Rollouts]],
    fig_dir: Path,
    algo: str,
    horizons: list[int],
) -> dict[str, Path]:
    """The figures of an evaluation: final-distance histogram, the policy's errors over the
    goals, policy vs oracle per episode (headline condition), distance vs step (longest
    horizon, per starting state), and per condition the paths of the first episodes (Track,
    Obstacle)."""
    headline, env = result["headline_condition"], result["env_id"].split("/")[-1]
    runs = raw[headline]
    pol_mm = runs["policy"].final_distance * 1000.0
    orc_mm = runs["oracle"].final_distance * 1000.0
    where = f"{env}, {headline}"
    n = result["episodes"]
    figures = {
        "histogram": plots.plot_error_histogram(
            {f"{algo} policy": pol_mm, "oracle": orc_mm},
            fig_dir / "error_histogram.png",
            f"final tip error ({where}, {n} episodes)",
        ),
        "workspace": plots.plot_workspace_errors(
            runs["policy"].goals,
            pol_mm,
            fig_dir / "workspace_errors.png",
            f"{algo} final error over the workspace ({where})",
        ),
        "policy_vs_oracle": plots.plot_policy_vs_oracle(
            pol_mm, orc_mm, fig_dir / "policy_vs_oracle.png", f"per episode ({where})"
        ),
    }
    curves = {}
    for name, cond in result["conditions"].items():
        if cond["horizon"] == max(horizons):
            curves[f"{algo} ({cond['initial_state']})"] = raw[name]["policy"].distances
            curves[f"oracle ({cond['initial_state']})"] = raw[name]["oracle"].distances
    figures["error_vs_step"] = plots.plot_error_vs_step(
        curves,
        fig_dir / "error_vs_step.png",
        result["train_horizon"],
        f"tip error vs step ({env}, {n} episodes)",
    )
    for name, runs in raw.items():
        path = fig_dir / f"{name}_paths.png"
        plot_paths(result["task"], {who: r.paths for who, r in runs.items()}, path)
        if path.is_file():
            figures[f"{name}_paths"] = path
    return figures


def _write_video(
    env_id: str,
    env_kwargs: dict[str, Any],
    policy: Any,
    specs: EpisodeSpecs,
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
            obs, info = env.reset(**specs.reset_kwargs(i))
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


def print_table(result: dict[str, Any], wide: bool = False) -> None:
    """The evaluation's table: one row per condition and policy (the task's columns,
    :func:`training.evaluate.tables.task_columns`), a legend under it."""
    print(
        tables.wrap(
            f"{result['task']} on {result['env_id']}: {result['episodes']} episodes per "
            f"condition, model at step {result['model_step']}; every policy on the same episodes"
        )
    )
    rows = [
        (name, who, s)
        for name, cond in result["conditions"].items()
        for who, s in cond.items()
        if isinstance(s, dict)
    ]
    columns = tables.task_columns(result["task"])
    print(tables.text_table(columns, rows, wide))
    print(tables.legend(columns, wide))
    if "_json_path" in result:
        print(tables.wrap(f"wrote {result['_json_path']} and figures in {result['run_dir']}"))


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
        description="Evaluate a trained run (best model) beside its task's oracle and baselines.",
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
    print_table(result, args.wide)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())
