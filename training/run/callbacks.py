"""The callbacks of a training run: episode statistics, checkpoints, periodic evaluation, wall time."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from training.run.checkpoints import save_checkpoint, save_model_dir
from training.run.config import (
    ExperimentConfig,
)
from training.run.envs import registered_steps, registered_task
from training.run.logs import append_csv
from training.run.metrics import run_task_episodes, summarize
from training.run.provenance import write_json
from training.run.rollout import (
    SB3Policy,
    concat_specs,
    make_env,
    make_specs,
    robot_of,
    run_episodes,
)
from training.run.rundir import RunDir


# -- callbacks ----------------------------------------------------------------------------------
def make_callbacks(config: ExperimentConfig, run: RunDir, state: dict[str, Any]) -> list[Any]:
    from stable_baselines3.common.callbacks import BaseCallback

    class StatsCallback(BaseCallback):
        """Logs the final tip error of finished training episodes (``charts/``)."""

        def __init__(self) -> None:
            super().__init__()
            self.final_errors: list[float] = []
            self.successes: list[float] = []

        def _on_step(self) -> bool:
            for done, info in zip(self.locals["dones"], self.locals["infos"], strict=False):
                if done and "distance" in info:
                    self.final_errors.append(float(info["distance"]) * 1000.0)
            return True

        def _on_rollout_end(self) -> None:
            if self.final_errors:
                self.logger.record("charts/final_error_mm_mean", float(np.mean(self.final_errors)))
                self.logger.record(
                    "charts/final_error_mm_median", float(np.median(self.final_errors))
                )
                self.final_errors = []
            optimizer = getattr(self.model.policy, "optimizer", None)
            if optimizer is None:  # SAC/TD3/TQC: one optimiser per network
                optimizer = self.model.actor.optimizer
            self.logger.record("charts/learning_rate", optimizer.param_groups[0]["lr"])

    class CheckpointCallback(BaseCallback):
        """Every ``checkpoint.freq`` env steps, at the next rollout start (after the update of
        the previous rollout, so nothing is half done): a checkpoint. A stop request (Ctrl-C,
        SIGTERM) also checkpoints there, then ends training at the next step."""

        def __init__(self) -> None:
            super().__init__()
            self.next_at = (
                state["start_steps"] // config.checkpoint.freq + 1
            ) * config.checkpoint.freq

        def _on_rollout_start(self) -> None:
            due = self.num_timesteps >= self.next_at
            if due or (state["stop_requested"] and not state["stopped"]):
                if state.get("last_checkpoint") != self.num_timesteps:
                    save_checkpoint(self.model, run, state)
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.checkpoint.freq
            if state["stop_requested"]:
                state["stopped"] = True

        def _on_step(self) -> bool:
            return not state["stopped"]

    class EvalCallback(BaseCallback):
        """Fixed-goal evaluation every ``eval.freq`` env steps; keeps the best model."""

        def __init__(self) -> None:
            super().__init__()
            ev = config.eval
            self.next_at = (state["start_steps"] // ev.freq + 1) * ev.freq
            params = robot_of(config.env.kwargs.get("params"))
            self.specs = concat_specs(
                [make_specs(ev.n_episodes, ev.seed, s, params) for s in ev.initial_states]
            )
            self.horizon = config.env.max_episode_steps or registered_steps(config.env.id)
            self.task = registered_task(config.env.id)

        def _task_row(self, policy: Any) -> dict[str, Any]:
            """Success, errors (mm) and return of the task's own metrics (training.run.metrics):
            the error is the tracking RMS for Track, the final distance otherwise."""

            e, ev = config.env, config.eval
            parts = []
            for start in ev.initial_states:
                kwargs = {**e.kwargs, "initial_state": start}
                parts.append(
                    run_task_episodes(
                        lambda k=kwargs: make_env(e.id, k, self.horizon),
                        policy,
                        ev.n_episodes,
                        ev.seed,
                    )
                )
            key = "tracking_rms_mm" if self.task == "Track" else "final_distance_mm"
            errors = np.concatenate([p[key] for p in parts])
            return {
                "timesteps": self.num_timesteps,
                "success_rate": float(np.mean(np.concatenate([p["success"] for p in parts]))),
                "within_1mm": float(np.mean(errors <= 1.0)),
                "mean_error_mm": float(np.mean(errors)),
                "median_error_mm": float(np.median(errors)),
                "p95_error_mm": float(np.percentile(errors, 95)),
                "max_error_mm": float(np.max(errors)),
                "mean_reward": float(np.mean(np.concatenate([p["return"] for p in parts]))),
            }

        def _evaluate(self) -> None:
            vecnorm = self.model.get_vec_normalize_env()
            policy = SB3Policy.from_model(self.model, vecnorm)
            e = config.env
            t0 = time.perf_counter()
            if self.task != "Reach":
                row = self._task_row(policy)
                row["wall_time_s"] = state["wall_before"] + time.perf_counter() - state["t_start"]
                self._record(row, vecnorm, t0)
                return
            rollouts = run_episodes(
                lambda: make_env(e.id, e.kwargs, self.horizon), policy, self.specs, self.horizon
            )
            threshold = config.env.kwargs.get("distance_threshold", 0.005)
            stats = summarize(rollouts.final_distance, threshold)
            row = {
                "timesteps": self.num_timesteps,
                "success_rate": stats["success_rate"],
                "within_1mm": stats["within_1mm"],
                "mean_error_mm": stats["error_mm"]["mean"],
                "median_error_mm": stats["error_mm"]["median"],
                "p95_error_mm": stats["error_mm"]["p95"],
                "max_error_mm": stats["error_mm"]["max"],
                "mean_reward": float(np.mean(rollouts.returns)),
                "wall_time_s": state["wall_before"] + time.perf_counter() - state["t_start"],
            }
            self._record(row, vecnorm, t0)

        def _record(self, row: dict[str, Any], vecnorm: Any, t0: float) -> None:
            for key in (
                "success_rate",
                "within_1mm",
                "mean_error_mm",
                "median_error_mm",
                "p95_error_mm",
                "mean_reward",
            ):
                self.logger.record(f"eval/{key}", row[key])
            self.logger.record("eval/duration_s", time.perf_counter() - t0)
            append_csv(run.eval_log, row)
            state["last_eval_step"] = self.num_timesteps
            metric = config.eval.best_metric
            score = {
                "mean_error": -row["mean_error_mm"],
                "median_error": -row["median_error_mm"],
                "success_rate": row["success_rate"] - 1e-6 * row["mean_error_mm"],
                "mean_reward": row["mean_reward"],
            }[metric]
            if state.get("best_score") is None or score > state["best_score"]:
                state["best_score"] = score
                run.best.mkdir(parents=True, exist_ok=True)
                save_model_dir(self.model, run.best)
                write_json(run.best / "info.json", {**row, "best_metric": metric})
                self.logger.record("eval/best_step", self.num_timesteps)

        def _on_training_start(self) -> None:
            # A policy cloned from demonstrations is evaluated before PPO changes it (step 0).
            if config.demonstrations.episodes and state["start_steps"] == 0:
                self._evaluate()

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next_at and not state["stop_requested"]:
                self._evaluate()
                while self.next_at <= self.num_timesteps:
                    self.next_at += config.eval.freq
            return True

        def _on_training_end(self) -> None:
            # Always evaluate the final weights too (the best model may be the last one).
            if (
                state.get("last_eval_step") != self.num_timesteps
                and not state["stop_requested"]
                and (self.num_timesteps >= state["total"] or state.get("stopped_by_wall_time"))
            ):
                self._evaluate()

    class CurriculumCallback(BaseCallback):
        """Before every rollout: the training envs' task difficulty for the steps done so far
        (``curriculum``; a resumed run continues where it was). Logged as
        ``charts/difficulty``."""

        def _on_rollout_start(self) -> None:
            difficulty = config.curriculum.difficulty(self.num_timesteps)
            self.training_env.env_method("set_difficulty", difficulty)
            self.logger.record("charts/difficulty", difficulty)

        def _on_step(self) -> bool:
            return True

    class WallTimeCallback(BaseCallback):
        """Stops training once ``runtime.max_wall_time_s`` of training wall time has passed."""

        def _on_step(self) -> bool:
            limit = config.runtime.max_wall_time_s
            elapsed = state["wall_before"] + time.perf_counter() - state["t_start"]
            if limit is not None and elapsed >= limit:
                state["stopped_by_wall_time"] = True
                return False
            return True

    # The wall-time check runs last, so the step that hits the limit is still logged/evaluated.
    callbacks = [StatsCallback(), CheckpointCallback(), EvalCallback(), WallTimeCallback()]
    if config.curriculum.steps > 0:
        callbacks.insert(0, CurriculumCallback())
    return callbacks
