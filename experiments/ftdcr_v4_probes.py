"""Two candidate terms for the FTDCR v4 calibration, probed on the selected CCKA fit without
refitting it (docs/experiments/real_robot.md):

* a marker offset ACROSS the tip (besides the fitted one along the tangent), in the frame that
  turns the base axis onto the tip tangent, fitted by linear least squares on the training
  residuals (aligned: their mean removed) and applied to both files;
* a latency τ between command and measurement: every row's commands interpolated at t − τ
  between the previous row's and its own (held at the previous row's over a gap shorter
  than τ).

Usage: python -m experiments.ftdcr_v4_probes   (prints aligned RMSEs in mm, train and held-out)
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.report import error_stats, load_fitted
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params_yaml import load_yaml

FIT = Path("docs/figures/calibration/ftdcr_v4_ccka_selected/params.yaml")
DATA = Path("data/real/ftdcr_v4")
LATENCIES = (0.0, 0.05, 0.1, 0.15, 0.2, 0.3)


def _setup():
    robot, _ = load_fitted(FIT)
    drive = TendonDrive.of(robot)
    fitted = load_yaml(FIT)["calibration"]["fitted"]
    # the fitted robot carries E, T0, angles, compliance; the frame and backlash are values
    values = {
        k: float(v)
        for k, v in fitted.items()
        if k.startswith(("base_", "marker")) or k == "drive_backlash"
    }
    files = {f: read_csv(DATA / f"{f}.csv", robot=robot, drive=drive) for f in ("train", "val")}
    return robot, drive, values, files


def tip_frames(tangent: np.ndarray) -> np.ndarray:
    """(M, 3, 3): the rotations turning Z onto each unit tangent (M, 3) about Z × t."""
    z = np.array([0.0, 0.0, 1.0])
    out = np.empty((len(tangent), 3, 3))
    for i, v in enumerate(tangent / np.linalg.norm(tangent, axis=1, keepdims=True)):
        a = np.cross(z, v)
        s, c = np.linalg.norm(a), float(v @ z)
        if s < 1e-12:
            out[i] = np.eye(3)
            continue
        k = a / s
        kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        out[i] = np.eye(3) + s * kx + (1 - c) * kx @ kx
    return out


def _rmse(err: np.ndarray) -> float:
    e = err - err.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))) * 1e3)


def marker_across() -> None:
    robot, drive, values, files = _setup()
    pred = {f: DriveReplay(d, robot, drive)(values) for f, d in files.items()}
    frames = {f: tip_frames(p.tip_direction) for f, p in pred.items()}
    x = frames["train"][:, :, :2]  # (M, 3, 2): the offsets' directions
    r = files["train"].tip - pred["train"].tip
    xc, rc = x - x.mean(axis=0), r - r.mean(axis=0)
    delta, *_ = np.linalg.lstsq(xc.reshape(-1, 2), rc.reshape(-1), rcond=None)
    print(f"marker offset across the tip: {np.round(delta * 1e3, 3).tolist()} mm")
    for f in files:
        moved = pred[f].tip + frames[f][:, :, :2] @ delta
        print(
            f"  {f}: {_rmse(pred[f].tip - files[f].tip):.3f} -> "
            f"{_rmse(moved - files[f].tip):.3f} mm"
        )


def latency() -> None:
    robot, drive, values, files = _setup()
    for f, data in files.items():
        t, d = data.timestamps, data.displacements
        assert t is not None and d is not None
        gap = np.r_[np.inf, np.diff(t)]
        previous = np.r_[0, np.arange(len(t) - 1)]
        row = []
        for tau in LATENCIES:
            lam = np.clip(1.0 - tau / gap, 0.0, 1.0)[:, None]
            late = d[previous] + lam * (d - d[previous])
            tip = DriveReplay(replace(data, displacements=late), robot, drive)(values).tip
            row.append(f"{tau:g} s: {error_stats(tip, data.tip)['rmse_aligned_mm']:.3f}")
        print(f"latency, {f}: " + ", ".join(row))


def main(argv: list[str] | None = None) -> None:
    import argparse

    argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_probes", description=__doc__.splitlines()[0]
    ).parse_args(argv)
    marker_across()
    latency()


if __name__ == "__main__":
    main()
