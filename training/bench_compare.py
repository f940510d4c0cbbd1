"""Side-by-side timing of two checkouts of cdcr_gym (e.g. before/after a refactor), run as a script.

    git worktree add /tmp/pre d9c52c3
    PYTHONPATH=/tmp/pre python training/bench_compare.py pre-refactor
    PYTHONPATH=.        python training/bench_compare.py now

``cdcr_gym`` is imported from ``PYTHONPATH`` (so the same loop times any checkout, including ones
older than ``training.bench``). Prints the batched CCKA reach env at 16 384 envs (M env-steps/s,
median of 5 × 60 steps) and the single env through ``gym.make`` beside ``Pendulum-v1`` (env-steps/s,
median of 5 × 20 000 steps, resets included). Alternate the checkouts a few times: the machine is
shared, so only numbers taken close together compare.
"""

from __future__ import annotations

import sys
import time

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401 - registers the ids


def batched_rate(num_envs: int = 16384, steps: int = 60, repeats: int = 5) -> float:
    """Median env-steps/s of the batched reach env (vector_entry_point) with random actions."""
    env = gym.make_vec(
        "cdcr_gym/CCKAReach-v0", num_envs=num_envs, vectorization_mode="vector_entry_point"
    )
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, env.action_space.shape).astype(np.float32) for _ in range(8)]
    for i in range(10):  # warm-up
        env.step(actions[i % 8])
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(steps):
            env.step(actions[i % 8])
        rates.append(num_envs * steps / (time.perf_counter() - start))
    env.close()
    return float(np.median(rates))


def single_rate(env_id: str, steps: int = 20000, repeats: int = 5) -> float:
    """Median env-steps/s of one env made by ``gym.make`` (default wrappers), resets included."""
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(64)]
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(steps):
            out = env.step(actions[i & 63])
            if out[2] or out[3]:
                env.reset()
        rates.append(steps / (time.perf_counter() - start))
    env.close()
    return float(np.median(rates))


if __name__ == "__main__":
    label = sys.argv[1] if len(sys.argv) > 1 else "this checkout"
    ccka = single_rate("cdcr_gym/CCKAReach-v0")
    pendulum = single_rate("Pendulum-v1")
    print(
        f"{label}: batched 16384 envs {batched_rate() / 1e6:.2f} M env-steps/s; single env "
        f"{ccka / 1e3:.1f} k, Pendulum-v1 {pendulum / 1e3:.1f} k, ratio {ccka / pendulum:.3f}",
        flush=True,
    )
