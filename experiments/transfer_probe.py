"""Probes of the CCKA → bullet gap that a CCKA-trained closed-loop policy meets
(docs/experiments/sim2real.md).

Usage::

    python -m experiments.transfer_probe [--trace RUN_DIR] [--friction MU]

Prints, on the paper robot:

1. **Co-tension compliance.** The tip's radial displacement (mm) under a tension difference
   ΔT on cable 1 added to an equal base tension T₀ on all three cables, static equilibrium, on
   CCKA (where T₀ has no effect: three equal tensions make no moment) and on bullet with gravity
   (where T₀ compresses the backbone and sag adds to the bend).
2. **Small-signal step response** on bullet with gravity: from rest at the tensions
   (17, 2.5, 57) N, cable 3 stepped by +2 N and held; the remaining fraction of the final tip
   move after k control steps, beside the critically damped ω = 0.44 rad/step model
   (``imperfections={"tension_response": 0.44}``): (1 + ωk)·e^(−ωk).
3. With ``--trace RUN_DIR``: the run's best policy on ``BulletReach-v0`` (gravity on, friction
   ``--friction``), straight start, the first evaluation goal (reset seed 1 000 000): tip error
   and actions per step over 150 steps, and the zero crossings of the error's largest component
   after step 40 (the closed-loop oscillation's period).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import gymnasium as gym
import numpy as np

import cdcr_gym  # noqa: F401
from cdcr_gym.backends.analytic import AnalyticBackend
from cdcr_gym.backends.bullet.backend import BulletBackend
from cdcr_gym.params import RobotParams
from training.run.argtypes import non_negative_float
from training.run.rollout import SB3Policy

__all__ = ["cotension_table", "step_response", "trace", "main"]


def _tip(backend, tensions: np.ndarray) -> np.ndarray:
    return np.asarray(backend.equilibrium(np.asarray(tensions, float)[None]).tip).reshape(-1, 3)[0]


def cotension_table(
    base_tensions: tuple[float, ...] = (0.0, 10.0, 20.0, 40.0), deltas: tuple[float, ...] = (10, 30)
) -> list[tuple[float, float, float, float]]:
    """Rows (T₀ N, ΔT N, CCKA radial mm, bullet-with-gravity radial mm)."""

    p = RobotParams()
    analytic, bullet = AnalyticBackend(p), BulletBackend(p, gravity=True)
    rows = []
    for t0 in base_tensions:
        for d in deltas:
            t = np.full(p.n_cables, float(t0))
            t[0] += d
            a, b = _tip(analytic, t), _tip(bullet, t)
            rows.append((t0, float(d), 1e3 * math.hypot(a[0], a[1]), 1e3 * math.hypot(b[0], b[1])))
    return rows


def step_response(steps: int = 40, omega: float = 0.44) -> tuple[np.ndarray, np.ndarray, float]:
    """(bullet remaining fraction (steps,), model remaining fraction (steps,), final move mm)."""

    env = gym.make(
        "cdcr_gym/BulletReach-v0", action_mode="tension", gravity=True, max_episode_steps=400
    )
    max_t = env.unwrapped.params.max_tension
    t0 = np.array([17.0, 2.5, 57.0])
    env.reset(seed=0)
    for _ in range(60):
        _, _, _, _, info = env.step(2 * t0 / max_t - 1)
    x0 = info["tip"].copy()
    t1 = t0 + np.array([0.0, 0.0, 2.0])
    moves = []
    for _ in range(steps):
        _, _, _, _, info = env.step(2 * t1 / max_t - 1)
        moves.append(info["tip"] - x0)
    env.close()
    d = np.array(moves)
    final = d[-1]
    remaining = 1.0 - d @ final / (final @ final)
    k = np.arange(1, steps + 1)
    model = (1 + omega * k) * np.exp(-omega * k)
    return remaining, model, float(1e3 * np.linalg.norm(final))


def trace(run_dir: str | Path, friction: float = 0.0, steps: int = 150) -> dict:
    """The closed-loop trace of a run's best policy on bullet (module docstring, item 3)."""

    run = Path(run_dir)
    policy = SB3Policy(run / "best_model" / "model.zip", run / "best_model" / "vecnormalize.pkl")
    env = gym.make(
        "cdcr_gym/BulletReach-v0",
        action_mode="tension_delta",
        tension_step=0.05,
        gravity=True,
        friction_coefficient=friction,
        initial_state="straight",
        max_episode_steps=steps,
    )
    obs, info = env.reset(seed=1_000_000)
    goal = info["goal"]
    errors, actions, tensions = [], [], []
    for _ in range(steps):
        a = policy(obs[None])[0]
        obs, _, _, _, info = env.step(a)
        errors.append(1e3 * (info["tip"] - goal))
        actions.append(a)
        tensions.append(info["tensions"])
    env.close()
    e = np.array(errors)
    axis = int(np.argmax(np.abs(e[40:]).max(axis=0)))
    sign = np.sign(e[40:, axis])
    crossings = (np.flatnonzero(sign[1:] != sign[:-1]) + 41).tolist()
    return {
        "error_mm": e,
        "actions": np.array(actions),
        "tensions": np.array(tensions),
        "axis": axis,
        "crossings": crossings,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.transfer_probe", description=__doc__
    )
    parser.add_argument("--trace", default=None, help="a run directory: trace its policy")
    parser.add_argument(
        "--friction", type=non_negative_float, default=0.0, help="bullet μ for --trace"
    )
    args = parser.parse_args(argv)
    if args.trace is not None:
        best = Path(args.trace) / "best_model" / "model.zip"
        if not best.is_file():
            parser.error(
                f"--trace {args.trace!r}: not a run directory with {best.relative_to(args.trace)}"
            )
    print("co-tension: radial tip displacement (mm), static, cable 1 at T0 + dT, cables 2, 3 at T0")
    print("| T0 (N) | dT (N) | CCKA | bullet, gravity | bullet / CCKA |")
    print("|---|---|---|---|---|")
    for t0, d, a, b in cotension_table():
        print(f"| {t0:.0f} | {d:.0f} | {a:.1f} | {b:.1f} | {b / a:.3f} |")
    remaining, model, final = step_response()
    print(
        f"\nstep response on bullet (gravity) at (17, 2.5, 57) N, +2 N on cable 3: {final:.2f} mm"
    )
    ks = [1, 2, 3, 4, 5, 6, 8, 10, 12]
    print("| step k | " + " | ".join(str(k) for k in ks) + " |")
    print("|---" * (len(ks) + 1) + "|")
    print("| bullet | " + " | ".join(f"{remaining[k - 1]:.3f}" for k in ks) + " |")
    print("| ω = 0.44 model | " + " | ".join(f"{model[k - 1]:.3f}" for k in ks) + " |")
    if args.trace:
        tr = trace(args.trace, args.friction)
        e = tr["error_mm"]
        norm = np.linalg.norm(e, axis=1)
        print(f"\ntrace of {args.trace} on bullet (gravity, mu={args.friction}), straight start:")
        for k in (25, 50, 75, 100, 125, 150):
            print(f"  step {k}: |error| {norm[k - 1]:.2f} mm")
        c = tr["crossings"]
        if len(c) >= 3:
            period = 2 * float(np.mean(np.diff(c)))
            print(
                f"  error axis {tr['axis']}: {len(c)} zero crossings after step 40, period ≈ "
                f"{period:.1f} steps"
            )
        late = tr["actions"][100:]
        print(f"  actions, steps 101-150: mean |a| {np.abs(late).mean():.3f}, std {late.std():.3f}")
        print(f"  final tensions (N): {np.round(tr['tensions'][-1], 1).tolist()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
