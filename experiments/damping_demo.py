"""Fitting the damping ratio back from a synthetic step response (``--damping-step`` demo).

``python -m experiments.damping_demo [--out docs/figures/calibration/damping]``

For each backend (MuJoCo at 20 ms, bullet at 10 ms, gravity on, the paper robot) and each known
``damping_ratio`` (0.3, 0.7): the robot rests bent by 10 % of ``max_tension`` on cable 0, at
t = 0 the cable is released (the step command: cable 0 from 8 N to 0 N), the tip is recorded
every physics step for 2 s, Gaussian noise of 0.1 mm is added to x, y, z, the CSV is written
(``step_<backend>_<ζ>.csv``) and fitted back with ``cdcr-gym calibrate --damping-step``'s fit
(``cdcr_gym.calibration.damping.fit_step_response``). Outputs: the CSVs, ``fit.json`` (known vs
fitted ζ, f₁), ``fit.png``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from cdcr_gym.calibration.damping import (
    StepResponse,
    fit_step_response,
    read_step_csv,
    simulate_step,
    write_step_csv,
)
from cdcr_gym.model.params import RobotParams

__all__ = ["synthetic_step"]

NOISE = 1e-4  # m, per coordinate
TIMESTEPS = {"mujoco": 0.02, "bullet": 0.01}


def synthetic_step(
    backend: str, zeta: float, seed: int = 0, duration: float = 2.0, noise: float = NOISE
) -> StepResponse:
    """A released-cable step response of the paper robot on ``backend`` with ``damping_ratio``
    ``zeta``, gravity on, Gaussian ``noise`` (m) added."""
    params = RobotParams.preset("paper")
    h = TIMESTEPS[backend]
    kw = {"gravity": True, "damping_ratio": zeta, "physics_timestep": h, "control_timestep": h}
    if backend == "mujoco":
        from cdcr_gym.backends.mujoco import MuJoCoBackend

        be = MuJoCoBackend(params, **kw)
    else:
        from cdcr_gym.backends.bullet import BulletBackend

        be = BulletBackend(params, **kw)
    before = np.zeros(params.n_cables)
    before[0] = 0.1 * params.max_tension
    try:
        clean = simulate_step(be, before, np.zeros(params.n_cables), duration)
    finally:
        be.close()
    rng = np.random.default_rng(seed)
    return StepResponse(clean.t, clean.tips + rng.normal(0.0, noise, clean.tips.shape))


def run(out: Path) -> dict:  # pragma: no cover (the CLI; tests call the pieces)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for backend in ("mujoco", "bullet"):
        for zeta in (0.3, 0.7):
            path = out / f"step_{backend}_{zeta}.csv"
            write_step_csv(
                path,
                synthetic_step(backend, zeta),
                f"synthetic step response: paper robot, {backend}, damping_ratio={zeta}, "
                f"gravity on\ncable 0 released from {0.1 * RobotParams.preset('paper').max_tension:.0f} N to 0 N at t = 0; "
                f"noise {NOISE * 1e3} mm\nmade by python -m experiments.damping_demo",
            )
            fit = fit_step_response(path)
            row = {
                "backend": backend,
                "file": path.name,
                "damping_ratio_known": zeta,
                "damping_ratio_fit": fit.damping_ratio,
                "error_pct": 100.0 * (fit.damping_ratio - zeta) / zeta,
                "frequency_hz_fit": fit.frequency_hz,
                "rms_mm": 1e3 * fit.rms_m,
                "command": f"cdcr-gym calibrate --damping-step {path}",
            }
            rows.append(row)
            print(
                f"{backend:6s} ζ = {zeta}: fitted {fit.damping_ratio:.4f} "
                f"({row['error_pct']:+.2f} %), f1 {fit.frequency_hz:.3f} Hz",
                flush=True,
            )
    result = {"command": "python -m experiments.damping_demo", "noise_m": NOISE, "rows": rows}
    (out / "fit.json").write_text(json.dumps(result, indent=2) + "\n")
    _plot(out, rows)
    return result


def _plot(out: Path, rows: list[dict]) -> None:  # pragma: no cover
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for row in rows:
        data = read_step_csv(out / row["file"])
        tip = data.tips - data.tips[-1]
        axis = tip[0] / np.linalg.norm(tip[0])
        ax.plot(
            data.t,
            1e3 * tip @ axis,
            ".",
            ms=3,
            label=f"{row['backend']}, ζ = {row['damping_ratio_known']} → fit "
            f"{row['damping_ratio_fit']:.3f}",
        )
    ax.set_xlabel("t (s) after the step")
    ax.set_ylabel("tip deflection (mm)")
    ax.set_title("Synthetic step responses (0.1 mm noise) and the fitted ζ")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "fit.png", dpi=100)


def main(argv: list[str] | None = None) -> None:  # pragma: no cover
    parser = argparse.ArgumentParser(
        prog="python -m experiments.damping_demo", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--out", type=Path, default=Path("docs/figures/calibration/damping"))
    run(parser.parse_args(argv).out)


if __name__ == "__main__":  # pragma: no cover
    main()
