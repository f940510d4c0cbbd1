"""Step time of the batched CCKA env with and without randomisation and imperfections.

``python -m training.bench_realism [--num-envs N] [--steps S] [--repeats R]``: the median over R
repeats of S steps of ``gymnasium.make_vec("cdcr_gym/CCKAReach-v0", num_envs=N)`` with zero
actions, plain and with ``randomize`` (E, cable radius) plus ``imperfections`` (tip noise,
tension lag, actuator noise), in µs per step. Run it in two checkouts to compare commits.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

#: The randomisation and imperfections timed by the second row.
RANDOMIZE = {"youngs_modulus": [30e9, 40e9], "cable_radius": [0.027, 0.031]}
IMPERFECTIONS = {"tip_noise": 1e-3, "tension_lag": 2.0, "actuator_noise": 0.2}


def step_time(num_envs: int, steps: int, repeats: int, **kwargs) -> float:
    """Median wall time of one batched step (s)."""
    import gymnasium as gym

    import cdcr_gym  # noqa: F401 - registers the ids

    env = gym.make_vec(
        "cdcr_gym/CCKAReach-v0",
        num_envs=num_envs,
        vectorization_mode="vector_entry_point",
        **kwargs,
    )
    env.reset(seed=0)
    action = np.zeros((num_envs, 3), np.float32)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(action)
        times.append((time.perf_counter() - t0) / steps)
    env.close()
    return float(np.median(times))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m training.bench_realism", description=__doc__)
    parser.add_argument("--num-envs", type=int, default=256)
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args(argv)
    rows = {
        "plain": {},
        "randomize + imperfections": {"randomize": RANDOMIZE, "imperfections": IMPERFECTIONS},
    }
    for name, kwargs in rows.items():
        t = step_time(args.num_envs, args.steps, args.repeats, **kwargs)
        print(f"{name:<28} {t * 1e6:9.1f} us/step  ({args.num_envs} envs)")


if __name__ == "__main__":
    main()
