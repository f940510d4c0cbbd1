"""Hysteresis study: cable–disk friction in the paper's load sweep (the paper's error source ii).

``python -m experiments.hysteresis [--out DIR] [--ramp-steps R] [--settle-steps N]``: on the
physics backend (paper robot, gravity off as in the paper's simulation), cable 1 is loaded from
0 to 80 N and back in 10 N steps, each ramped linearly over ``--ramp-steps`` control steps of
20 ms (default 25 = 0.5 s: slow enough that the backbone does not overshoot and reverse the
cable's sliding) and then settled (``--settle-steps``, default 50 = 1 s), for μ = 0, 0.1, 0.2,
0.3 (``friction_coefficient``). Printed and written (``DIR/hysteresis.json``,
``DIR/hysteresis.png``, default ``DIR = docs/figures/sim2real``):

* the loop width: the largest distance between the loading and the unloading tip at the same
  tension, in mm and in % of ℓ;
* the loading branch against the **capstan prediction**: the static equilibrium with every
  segment's tension decayed disk by disk, T_k = T·exp(−μ Σ_{j≤k} α_j) (full slip, s = 1), solved
  by a fixed point on the wrap angles; the largest distance in mm;
* CCKA's error: the CCKA forward kinematics fed with the simulated cable lengths vs the
  simulated tip, mean over each branch, in mm.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from cdcr_gym import kinematics as K
from cdcr_gym.backends.bullet import BulletBackend
from cdcr_gym.model import friction
from training.run.argtypes import non_negative_int, positive_int

MUS = (0.0, 0.1, 0.2, 0.3)
LOADS = tuple(float(t) for t in range(0, 81, 10))


def capstan_equilibrium(backend: Any, tension: float, mu: float) -> np.ndarray:
    """Tip (3,) m of the static equilibrium under ``tension`` N on cable 1 with the capstan
    profile of a pulled cable (s = 1) on every cable, no gravity (fixed point on q)."""

    chain = backend.chain
    t = np.array([tension, 0.0, 0.0])
    entry = chain.base_rotation[:, 2]
    q = np.zeros(chain.n_dof)
    for _ in range(2000):
        _, pins = chain.stations_and_pinholes(q)
        wraps = friction.wrap_angles(pins.transpose(1, 0, 2), entry)
        seg = friction.tension_profile(t, wraps, mu, 1.0).T
        q_new = chain.cable_loads(q, seg)[0] / chain.stiffness
        if np.max(np.abs(q_new - q)) < 1e-13:
            q = q_new
            break
        q = q_new
    stations, _ = chain.stations_and_pinholes(q)
    return chain.base_rotation.T @ stations[-1]


def run(ramp_steps: int, settle_steps: int) -> dict[str, Any]:
    """The sweep for every μ: tips, cable lengths and CCKA tips along both branches."""

    out: dict[str, Any] = {}
    loads = list(LOADS) + list(reversed(LOADS[:-1]))
    for mu in MUS:
        b = BulletBackend(gravity=False, friction_coefficient=mu)
        try:
            r_cable = b.params.cable_radii[0]
            tips, ccka, anchors = [], [], []
            previous = 0.0
            for t in loads:
                for k in range(1, ramp_steps + 1):
                    ramp = previous + (t - previous) * k / ramp_steps
                    b.apply_tensions(np.array([[ramp, 0.0, 0.0]]))
                for _ in range(settle_steps):
                    b.apply_tensions(np.array([[t, 0.0, 0.0]]))
                previous = t
                r = b.read()
                tips.append(r.tip[0])
                ccka.append(K.forward_kinematics(r.cable_lengths[0], r_cable))
                anchors.append(b.anchor_tensions[0])
            capstan = [capstan_equilibrium(b, t, mu) for t in LOADS]
        finally:
            b.close()
        tips_a, ccka_a = np.array(tips), np.array(ccka)
        n = len(LOADS)
        up, down = tips_a[:n], tips_a[n - 1 :][::-1]  # both indexed by LOADS
        ell = 0.641
        width = float(np.max(np.linalg.norm(up - down, axis=1)))
        err = np.linalg.norm(ccka_a - tips_a, axis=1)
        out[f"{mu:g}"] = {
            "loads_N": loads,
            "tip_mm": (tips_a * 1000).round(4).tolist(),
            "anchor_tension_N": np.round(anchors, 4).tolist(),
            "loop_width_mm": width * 1000,
            "loop_width_pct_length": 100 * width / ell,
            "capstan_vs_loading_max_mm": float(
                np.max(np.linalg.norm(np.array(capstan) - up, axis=1)) * 1000
            ),
            "ccka_error_loading_mean_mm": float(err[:n].mean() * 1000),
            "ccka_error_unloading_mean_mm": float(err[n - 1 :].mean() * 1000),
        }
    return out


def plot(result: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for mu, res in result.items():
        tips = np.array(res["tip_mm"])
        ax.plot(res["loads_N"], tips[:, 0], marker="o", ms=3, label=f"μ = {mu}")
    ax.set_xlabel("tension on cable 1 (N), loading then unloading")
    ax.set_ylabel("tip x (mm)")
    ax.set_title("Cable–disk friction: tip vs tension loops (bullet, no gravity)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m experiments.hysteresis", description=__doc__)
    parser.add_argument("--out", type=Path, default=Path("docs/figures/sim2real"))
    parser.add_argument("--ramp-steps", type=positive_int, default=25)
    parser.add_argument("--settle-steps", type=non_negative_int, default=50)
    args = parser.parse_args(argv)
    result = run(args.ramp_steps, args.settle_steps)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "hysteresis.json").write_text(json.dumps(result, indent=1))
    plot(result, args.out / "hysteresis.png")
    print(
        "| μ | loop width (mm) | % of ℓ | capstan vs loading (max, mm) | CCKA error loading / unloading (mean, mm) |"
    )
    print("|---|---|---|---|---|")
    for mu, r in result.items():
        print(
            f"| {mu} | {r['loop_width_mm']:.2f} | {r['loop_width_pct_length']:.2f} | "
            f"{r['capstan_vs_loading_max_mm']:.2f} | {r['ccka_error_loading_mean_mm']:.2f} / "
            f"{r['ccka_error_unloading_mean_mm']:.2f} |"
        )
    print(f"wrote {args.out / 'hysteresis.json'} and {args.out / 'hysteresis.png'}")


if __name__ == "__main__":
    main()
