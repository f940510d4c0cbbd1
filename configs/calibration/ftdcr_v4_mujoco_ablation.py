"""What each error source is worth for the MuJoCo model of the FTDCR v4 robot, on the held-out
rows (val.csv), and the pybullet replay of the same fitted robot.

Usage (after configs/calibration/ftdcr_v4_mujoco.sh):
    python configs/calibration/ftdcr_v4_mujoco_ablation.py [OUT_DIR]

Every variant replays val.csv (in order, recorded timing, gaps capped at 1 s) with the MuJoCo
fit's values and ONE thing changed; the variants are not refitted (a refit per variant, as the
CCKA ablation does, costs a full physics fit each). Writes OUT_DIR/ablation.json and
OUT_DIR/ablation.md (default docs/figures/calibration/ftdcr_v4_mujoco).
"""

from __future__ import annotations

import json
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.report import error_stats, load_fitted
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params_yaml import load_yaml

DATA = Path("data/real/ftdcr_v4")
TIMING = {"physics_timestep": 0.04, "control_timestep": 0.04}


def main(out: Path) -> None:
    params_yaml = out / "params.yaml"
    robot, _ = load_fitted(params_yaml)
    doc = load_yaml(params_yaml)
    values = {k: float(v) for k, v in doc["calibration"]["fitted"].items()}
    drive = TendonDrive.of(robot)
    assert drive is not None
    val = read_csv(DATA / "val.csv", robot=robot, drive=drive)
    frame_names = ("base_x", "base_y", "base_z", "base_tilt_x", "base_tilt_y", "base_yaw")
    no_frame = {k: v for k, v in values.items() if k not in frame_names}
    rows: list[dict] = []

    def add(key: str, label: str, tip: np.ndarray, seconds: float) -> None:
        stats = error_stats(tip, val.tip)
        stats["percent_of_length"] = 100.0 * stats["mean_mm"] * 1e-3 / robot.length
        rows.append({"variant": key, "label": label, "seconds": round(seconds, 1), **stats})
        print(f"{key:>16s}: aligned RMSE {stats['rmse_aligned_mm']:.2f} mm ({seconds:.0f} s)")

    t0 = time.perf_counter()
    rep = PhysicsReplay(val, robot, drive, "mujoco", {"gravity": True, **TIMING})
    tips, _, _ = rep.batch([values, no_frame])
    dt = time.perf_counter() - t0
    add("full", "MuJoCo, fitted (gravity, compliant one-sided tendons)", tips[0], dt)
    add("no_base_frame", "no base frame (robot base = measurement frame)", tips[1], dt)

    t0 = time.perf_counter()
    rep = PhysicsReplay(val, robot, drive, "mujoco", {"gravity": False, **TIMING})
    nograv = rep(values).tip
    add("no_gravity", "no gravity (and so no payload)", nograv, time.perf_counter() - t0)

    t0 = time.perf_counter()
    rigid = TendonDrive(tuple(1000.0 * k for k in drive.stiffness), drive.pretension)
    rep = PhysicsReplay(val, robot, rigid, "mujoco", {"gravity": True, **TIMING})
    add("rigid_tendons", "rigid tendons (k x 1000)", rep(values).tip, time.perf_counter() - t0)

    t0 = time.perf_counter()
    rep = PhysicsReplay(val, robot, drive, "mujoco", {"gravity": True, **TIMING}, slack=False)
    add(
        "no_slack",
        "no slack: the linear law T = T0 + k(d - s)",
        rep(values).tip,
        time.perf_counter() - t0,
    )

    t0 = time.perf_counter()
    rep = PhysicsReplay(val, robot, drive, "mujoco", {"gravity": True, **TIMING})
    add(
        "friction_0.05",
        "with cable friction mu = 0.05 (the fit has none)",
        rep({**values, "friction_coefficient": 0.05}).tip,
        time.perf_counter() - t0,
    )

    t0 = time.perf_counter()
    bullet_robot = replace(robot)
    rep = PhysicsReplay(val, bullet_robot, drive, "bullet", {"gravity": True})
    add(
        "bullet",
        "pybullet replay of the MuJoCo-fitted robot",
        rep(values).tip,
        time.perf_counter() - t0,
    )

    # constant curvature against the physics model: the CCKA shapes of the same robot (no
    # gravity, frame applied) against the MuJoCo replay without gravity, and the measurements
    ccka = DriveReplay(val, robot, drive)(
        {k: v for k, v in values.items() if k not in ("youngs_modulus", "tip_payload")}
    ).tip
    add("ccka_same_robot", "CCKA of the same robot (no gravity; not refitted)", ccka, 0.0)
    dist = np.linalg.norm(ccka - nograv, axis=1) * 1e3
    cc_vs_physics = {
        "mean_mm": float(dist.mean()),
        "median_mm": float(np.median(dist)),
        "p95_mm": float(np.percentile(dist, 95)),
        "percent_of_length": float(100.0 * dist.mean() * 1e-3 / robot.length),
    }
    print("CCKA vs MuJoCo (no gravity):", cc_vs_physics)
    (out / "ablation.json").write_text(
        json.dumps({"rows": rows, "ccka_vs_mujoco_no_gravity": cc_vs_physics}, indent=1) + "\n"
    )
    lines = [
        "# MuJoCo ablation on the held-out rows (val.csv)",
        "",
        "Every variant replays the held-out rows with the MuJoCo fit's values and one thing "
        "changed (not refitted). Aligned RMSE: Euclidean tip RMSE after removing the mean "
        "offset (mm); X / Y / Z its components; % of length: the plain mean error over the "
        f"robot's length ({robot.length * 1e3:.1f} mm).",
        "",
        "| variant | aligned RMSE | X / Y / Z | mean | % of length |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        x, y, z = r["rmse_aligned_xyz_mm"]
        lines.append(
            f"| {r['label']} | {r['rmse_aligned_mm']:.2f} | {x:.2f} / {y:.2f} / {z:.2f} | "
            f"{r['mean_mm']:.2f} | {r['percent_of_length']:.2f} |"
        )
    c = cc_vs_physics
    lines += [
        "",
        f"Constant curvature against the physics model (same robot, no gravity): mean tip "
        f"distance {c['mean_mm']:.2f} mm ({c['percent_of_length']:.2f} % of length), median "
        f"{c['median_mm']:.2f} mm, 95th percentile {c['p95_mm']:.2f} mm.",
        "",
        "Command: `python configs/calibration/ftdcr_v4_mujoco_ablation.py`",
        "",
    ]
    (out / "ablation.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main(
        Path(sys.argv[1]) if len(sys.argv) > 1 else Path("docs/figures/calibration/ftdcr_v4_mujoco")
    )
