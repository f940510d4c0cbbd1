"""Step time of the batched CCKA env with and without randomisation and imperfections.

``python -m experiments.bench_realism [--num-envs N] [--steps S] [--repeats R]``: the median over R
repeats of S steps of ``gymnasium.make_vec("cdcr_gym/CCKAReach-v0", num_envs=N)`` with zero
actions, plain and with ``randomize`` (E, cable radius) plus ``imperfections`` (tip noise,
tension lag, actuator noise), in µs per step. Run it in two checkouts to compare commits.

``--bullet``: instead, the median time of a ``BulletReach-v0`` reset (R·5 resets, 5 random steps
between them) plain and with ``randomize`` (E, friction, gravity: applied in the running
pybullet client), next to the time to build the env and reset it once, and the time of a
control step of ``BulletBackend`` without and with cable friction (μ = 0.2).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym.backends.bullet import BulletBackend
from training.run.argtypes import positive_int

#: The randomisation and imperfections timed by the second row.
RANDOMIZE = {"youngs_modulus": [30e9, 40e9], "cable_radius": [0.027, 0.031]}
IMPERFECTIONS = {"tip_noise": 1e-3, "tension_lag": 2.0, "actuator_noise": 0.2}


def step_time(num_envs: int, steps: int, repeats: int, **kwargs) -> float:
    """Median wall time of one batched step (s)."""

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


#: The randomisation the bullet reset timing applies.
BULLET_RANDOMIZE = {
    "youngs_modulus": [30e9, 40e9],
    "friction_coefficient": [0.0, 0.3],
    "gravity": 0.5,
}


def bullet_resets(n: int) -> None:
    """Print the median reset time (ms) of BulletReach-v0, plain and randomised."""

    t0 = time.perf_counter()
    env = gym.make("cdcr_gym/BulletReach-v0")
    env.reset(seed=0)
    print(f"{'build + first reset':<28} {(time.perf_counter() - t0) * 1e3:9.1f} ms")
    env.close()
    for name, kwargs in (
        ("reset, plain", {}),
        ("reset, randomized", {"randomize": BULLET_RANDOMIZE}),
    ):
        env = gym.make("cdcr_gym/BulletReach-v0", **kwargs)
        times = []
        for k in range(n):
            t0 = time.perf_counter()
            env.reset(seed=k)
            times.append(time.perf_counter() - t0)
            for _ in range(5):
                env.step(env.action_space.sample())
        env.close()
        print(f"{name:<28} {np.median(times) * 1e3:9.1f} ms (median of {n})")

    rng = np.random.default_rng(0)
    commands = rng.uniform(0.0, 80.0, (200, 1, 3))
    for mu in (0.0, 0.2):
        backend = BulletBackend(friction_coefficient=mu)
        t0 = time.perf_counter()
        for t in commands:
            backend.apply_tensions(t)
        backend.close()
        step = (time.perf_counter() - t0) / len(commands)
        print(f"{f'control step, mu = {mu}':<28} {step * 1e3:9.2f} ms (mean of {len(commands)})")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.bench_realism", description=__doc__
    )
    parser.add_argument("--num-envs", type=positive_int, default=256)
    parser.add_argument("--steps", type=positive_int, default=200)
    parser.add_argument("--repeats", type=positive_int, default=7)
    parser.add_argument("--bullet", action="store_true", help="time BulletReach-v0 resets")
    args = parser.parse_args(argv)
    if args.bullet:
        bullet_resets(5 * args.repeats)
        return
    rows = {
        "plain": {},
        "randomize + imperfections": {"randomize": RANDOMIZE, "imperfections": IMPERFECTIONS},
    }
    for name, kwargs in rows.items():
        t = step_time(args.num_envs, args.steps, args.repeats, **kwargs)
        print(f"{name:<28} {t * 1e6:9.1f} us/step  ({args.num_envs} envs)")


if __name__ == "__main__":
    main()
