"""The cost of the tuned damping: construction and physics-step time with the tuned β against
the plain β = 2ζ/ω₁, interleaved in one run (medians of the repeats, their ratio).

``python -m experiments.damping_speed [--repeats 5]``

The tuned β only changes the value of D = β·K (the step does the same work); construction
computes gravity's stiffness and the stepped mode once (MuJoCo: 2·nv extra ``mj_forward``).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import cdcr_gym.backends.bullet.backend as bullet_module
import cdcr_gym.backends.mujoco.backend as mujoco_module

__all__ = ["measure"]


def _plain_mujoco(backend: Any, model: Any) -> float:
    first, _ = backend._modes(model)
    beta = 2.0 * backend.damping_ratio / first
    model.dof_damping[:] = beta * model.jnt_stiffness[model.dof_jntid]
    return beta


def _plain_bullet(backend: Any) -> float:
    return 2.0 * backend.damping_ratio / backend.first_mode_frequency


def _time(make: Callable[[], Any], steps: int) -> tuple[float, float]:
    t0 = time.perf_counter()
    be = make()
    t1 = time.perf_counter()
    tensions = np.random.default_rng(0).uniform(0.0, 40.0, (steps, 1, 3))
    t2 = time.perf_counter()
    for k in range(steps):
        be.apply_tensions(tensions[k])
    t3 = time.perf_counter()
    be.close()
    return t1 - t0, (t3 - t2) / steps


def measure(repeats: int = 5) -> dict:  # pragma: no cover (timing)
    from cdcr_gym.backends.bullet import BulletBackend
    from cdcr_gym.backends.mujoco import MuJoCoBackend

    tuned = {"mujoco": mujoco_module.tune_damping, "bullet": bullet_module.backend_damping_time}
    plain = {"mujoco": _plain_mujoco, "bullet": _plain_bullet}
    makers = {"mujoco": (MuJoCoBackend, 300), "bullet": (BulletBackend, 100)}
    times: dict = {}
    try:
        for _ in range(repeats):
            for label, hooks in (("plain", plain), ("tuned", tuned)):
                mujoco_module.tune_damping = hooks["mujoco"]
                bullet_module.backend_damping_time = hooks["bullet"]
                for name, (cls, steps) in makers.items():
                    times.setdefault((name, label), []).append(_time(cls, steps))
    finally:
        mujoco_module.tune_damping = tuned["mujoco"]
        bullet_module.backend_damping_time = tuned["bullet"]
    out = {}
    for name in makers:
        p = [statistics.median(x) for x in zip(*times[(name, "plain")])]
        t = [statistics.median(x) for x in zip(*times[(name, "tuned")])]
        out[name] = {
            "construction_ms": [1e3 * p[0], 1e3 * t[0]],
            "step_us": [1e6 * p[1], 1e6 * t[1]],
            "step_ratio": t[1] / p[1],
        }
        print(
            f"{name}: construction plain {1e3 * p[0]:.1f} ms, tuned {1e3 * t[0]:.1f} ms; "
            f"physics step plain {1e6 * p[1]:.0f} µs, tuned {1e6 * t[1]:.0f} µs "
            f"(×{t[1] / p[1]:.3f})"
        )
    return out


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    parser = argparse.ArgumentParser(
        prog="python -m experiments.damping_speed", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--repeats", type=int, default=5)
    measure(parser.parse_args(argv).repeats)


if __name__ == "__main__":  # pragma: no cover
    main()
