"""Where a reset of the MuJoCo twin's training envs goes, with the fast static solves and with
the plain iteration, in one run (the same episodes: the same seeds), and the plain stepping rate.

``python -m experiments.twin_mujoco_reset [--config configs/twin_ftdcr_v4_mujoco_reach.yaml]
[--repeats 3] [--out docs/figures/twin_ftdcr_v4/reset_time_mujoco.json]``

The envs are the config's training envs (``env.n_envs`` robots of one batched MuJoCo backend,
half starting straight and half from a random shape, displacement_delta). A reset's time is
split into the start shapes (``MuJoCoBackend.reset``: one static solve per robot) and the goals
(``Task.sample_goal_readings``: one static solve per goal under sampled tensions, and a
displacement equilibrium for the goals whose holding displacements leave the drives' range).
"Plain statics" replaces the Anderson-accelerated tension solves by the relaxed plain iteration
(``StaticSolve._solve_static``); "plain" also the drive solve by
``Backend.displacement_equilibrium``'s outer iteration on tension solves, as before the fast
solves (it may not converge for drives pulling far above ``max_tension``: then its error is
recorded). The goals of each are compared with the fast ones (max distance).
Stepping: ``steps`` control steps of all envs under uniform random actions, no resets.
Wall times and the process's CPU times (``*_cpu_s``: what a reset costs on a machine shared
with other jobs, where wall time also counts the waiting) are both recorded.
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym.backends.base import Backend
from training.run.config import load_config
from training.run.envs import build_vec_env


class Timed:
    """Wraps ``obj.name`` to add its wall time (s) to :attr:`seconds`."""

    def __init__(self, obj: Any, name: str) -> None:
        self.seconds = 0.0
        self.cpu_seconds = 0.0
        self.obj, self.name = obj, name
        self.saved = obj.__dict__.get(name)  # an instance attribute to restore (else none)
        inner = getattr(obj, name)

        def wrapper(*args: Any, **kwargs: Any) -> Any:
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - t0
                self.cpu_seconds += time.process_time() - c0

        setattr(obj, name, wrapper)

    def restore(self) -> None:
        if self.saved is None:
            delattr(self.obj, self.name)
        else:
            setattr(self.obj, self.name, self.saved)


def plain(backend: Any, drives: bool = True) -> None:
    """The backend's solves as before the fast static solves (module docstring); with
    ``drives=False`` the tension statics only (the drive solve stays)."""
    backend._solve_static_fast = lambda model, data, t, tol=1e-13: backend._solve_static(
        model, data, t, tol=tol
    )
    if drives:
        backend.displacement_equilibrium = functools.partial(
            Backend.displacement_equilibrium, backend
        )


def one_reset(vec: Any, seeds: list[int]) -> dict[str, Any]:
    """One reset of every env of the CDCRVectorEnv ``vec`` with ``seeds``: times and goals."""
    backend = vec.core.backend
    task = vec.core.task
    timers = {
        "start_shapes_s": Timed(backend, "reset"),
        "goals_s": Timed(task, "sample_goal_readings"),
        "goal_displacement_equilibria_s": Timed(backend, "displacement_equilibrium"),
    }
    t0, c0 = time.perf_counter(), time.process_time()
    _, info = vec.reset(seed=seeds)
    out = {"total_s": time.perf_counter() - t0, "total_cpu_s": time.process_time() - c0}
    out.update({k: t.seconds for k, t in timers.items()})
    out.update({k[:-2] + "_cpu_s": t.cpu_seconds for k, t in timers.items()})
    for t in timers.values():
        t.restore()
    out["goals"] = np.asarray(info["goal"]).copy()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m experiments.twin_mujoco_reset", description=__doc__.split("\n")[0]
    )
    ap.add_argument("--config", default="configs/twin_ftdcr_v4_mujoco_reach.yaml")
    ap.add_argument("--repeats", type=int, default=3, help="fast resets (the plain one: once)")
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument(
        "--out", type=Path, default=Path("docs/figures/twin_ftdcr_v4/reset_time_mujoco.json")
    )
    args = ap.parse_args(argv)
    config = load_config(args.config)
    venv = build_vec_env(config, seed=0)  # VecMonitor(BatchedVecEnv)
    vec = venv.venv.venv  # the CDCRVectorEnv
    n = vec.num_envs
    seeds = list(range(n))
    fast = [one_reset(vec, seeds) for _ in range(args.repeats)]
    rng = np.random.default_rng(0)
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(args.steps):
        vec.step(rng.uniform(-1.0, 1.0, (n, vec.single_action_space.shape[0])))
    steps_per_s = n * args.steps / (time.perf_counter() - t0)
    steps_per_cpu_s = n * args.steps / (time.process_time() - c0)
    keys = [k for k in fast[0] if k != "goals"]
    result: dict[str, Any] = {
        "command": "python -m experiments.twin_mujoco_reset " + " ".join(argv or []),
        "config": str(args.config),
        "n_envs": n,
        "fast_median": {k: statistics.median(r[k] for r in fast) for k in keys},
        "fast_repeats": args.repeats,
    }
    # the plain tension statics (the drive solve kept), then the plain drive solve too (the
    # outer iteration on tension solves: it may not converge for drives far above max_tension)
    for name, drives in (("plain_statics", False), ("plain", True)):
        plain(vec.core.backend, drives=drives)
        try:
            slow = one_reset(vec, seeds)
        except RuntimeError as err:
            result[name] = {"error": str(err)[:200]}
            continue
        result[name] = {k: slow[k] for k in keys}
        for clock in ("", "_cpu"):
            result[f"ratio_{name}_over_fast{clock or '_wall'}"] = slow[f"total{clock}_s"] / (
                statistics.median(r[f"total{clock}_s"] for r in fast)
            )
        result[f"max_goal_gap_{name}_m"] = float(
            np.max(np.linalg.norm(slow["goals"] - fast[0]["goals"], axis=1))
        )
    result["env_steps_per_s_no_resets"] = steps_per_s
    result["env_steps_per_cpu_s_no_resets"] = steps_per_cpu_s
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))
    venv.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
