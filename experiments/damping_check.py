"""Stated vs delivered damping ratio of the first bending mode, per backend.

``python -m experiments.damping_check [--out experiments/dynamics/damping.json] [--quick]``

For each backend at its default physics timestep (MuJoCo 20 ms, bullet 10 ms; one sample per
physics step), each stated ``damping_ratio`` ζ and gravity off/on: the robot rests bent by 5 %
of ``max_tension`` on cable 0, the cable is released (all cables slack) and the tip's
deflection along its initial direction is recorded; from 0.1 s on (``FIT_START``) ω₁ and ζ are fitted with the free response
of one damped mode (``cdcr_gym.calibration.damping.fit_second_order``; for ζ < 1 the same as the
logarithmic decrement of the peaks, and it also covers ζ >= 1). A ζ the step cannot deliver is
refused by the backend (``ValueError``): the table gives the message.
"""

from __future__ import annotations

import math

import numpy as np

from cdcr_gym.calibration.damping import fit_second_order
from cdcr_gym.model.params import RobotParams
from experiments._json_main import json_main

__all__ = ["release", "measure", "ZETAS", "TIMESTEPS", "FIT_START"]

#: The fit starts 0.1 s after the release: before, the higher modes still move (the second,
#: ζ₂ ≈ 6·ζ₁ at ω₂ ≈ 6·ω₁, has decayed to ~1 % by then at ζ₁ >= 0.3).
FIT_START = 0.1
ZETAS = (0.1, 0.2, 0.3, 0.5, 0.7, 1.0)
TIMESTEPS = {"mujoco": 0.02, "bullet": 0.01}


def _backend(backend: str, params: RobotParams, **kw):
    if backend == "mujoco":
        from cdcr_gym.backends.mujoco import MuJoCoBackend

        return MuJoCoBackend(params, **kw)
    from cdcr_gym.backends.bullet import BulletBackend

    return BulletBackend(params, **kw)


def release(
    backend: str, name: str, zeta: float, gravity: bool, duration: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Times (N,) s and tip deflection (N,) m along its initial direction after releasing the
    robot ``name`` bent by 5 % of ``max_tension`` on cable 0 (``backend`` at its default
    physics timestep, sampled every physics step)."""
    params = RobotParams.preset(name)
    h = TIMESTEPS[backend]
    be = _backend(
        backend,
        params,
        gravity=gravity,
        damping_ratio=zeta,
        physics_timestep=h,
        control_timestep=h,
    )
    try:
        pull = np.zeros((1, params.n_cables))
        pull[0, 0] = 0.05 * params.max_tension
        zero = np.zeros_like(pull)
        be.reset(zero)
        rest = be.read().tip[0].copy()
        be.reset(pull)
        tip0 = be.read().tip[0].copy()
        axis = (tip0 - rest) / np.linalg.norm(tip0 - rest)
        if duration is None:  # the decay to ~0.1 % (ω₁ ≈ 2π·3 Hz), at least 3 periods
            duration = max(7.0 / (min(zeta, 1.0) * 15.0), 1.0)
        n = int(round(duration / h))
        x = [float((tip0 - rest) @ axis)]
        for _ in range(n):
            be.apply_tensions(zero)
            x.append(float((be.read().tip[0] - rest) @ axis))
    finally:
        be.close()
    return h * np.arange(n + 1), np.asarray(x)


def measure(backend: str, name: str, zeta: float, gravity: bool) -> dict:
    """One row of the table: the delivered ζ and f₁ (or the refusal)."""
    row: dict = {
        "backend": backend,
        "robot": name,
        "gravity": gravity,
        "timestep_s": TIMESTEPS[backend],
        "damping_ratio_set": zeta,
    }
    try:
        t, x = release(backend, name, zeta, gravity)
    except ValueError as err:
        return {**row, "refused": str(err)}
    keep = t >= FIT_START
    w, z, rms = fit_second_order(t[keep], x[keep])
    return {
        **row,
        "damping_ratio_measured": z,
        "error_pct": 100.0 * (z - zeta) / zeta,
        "frequency_hz": w / (2.0 * math.pi),
        "fit_rms_m": rms,
    }


def run(quick: bool = False) -> dict:  # pragma: no cover (the CLI; tests call the pieces)
    cases = [
        (backend, "paper", zeta, grav)
        for backend in ("mujoco", "bullet")
        for grav in (False, True)
        for zeta in ((0.3, 0.7) if quick else ZETAS)
    ]
    if not quick:  # the robot where gravity lowers ω₁ most
        cases += [
            (backend, "tdcr2", zeta, True)
            for backend in ("mujoco", "bullet")
            for zeta in (0.3, 0.7)
        ]
    rows = []
    for backend, name, zeta, grav in cases:
        row = measure(backend, name, zeta, grav)
        rows.append(row)
        head = f"{backend:6s} {name:6s} g={int(grav)} h={row['timestep_s']:.3f} s ζ = {zeta:4.2f}:"
        if "refused" in row:
            print(head, "refused:", row["refused"], flush=True)
        else:
            print(
                f"{head} ζ_measured = {row['damping_ratio_measured']:.3f} "
                f"({row['error_pct']:+5.1f} %), f1 = {row['frequency_hz']:.3f} Hz",
                flush=True,
            )
    return {"command": "python -m experiments.damping_check", "rows": rows}


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    json_main(
        "python -m experiments.damping_check",
        __doc__,
        "experiments/dynamics/damping.json",
        "ζ 0.3 and 0.7 on the paper robot",
        run,
        argv,
    )


if __name__ == "__main__":  # pragma: no cover
    main()
