"""Where the fitted models of the FTDCR v4 robot miss on the held-out rows: the error per motion
pattern family (``same``, ``scurve``, ``spiral``), along X, Y, Z, and against the tip's
deflection from the straight pose, and inside against beyond the training file's command range
(a held-out row is "beyond" when any tendon's command lies outside that tendon's range over
train.csv).

Usage (after ftdcr_v4_ccka.sh and ftdcr_v4_mujoco.sh):
    python configs/calibration/ftdcr_v4_patterns.py [OUT_FILE_STEM]

Replays val.csv with the CCKA fits (docs/figures/calibration/ftdcr_v4_ccka*/params.yaml) and the
MuJoCo fits (ftdcr_v4_mujoco_helix/, the main one, ftdcr_v4_mujoco_selected/, the same from
parallel tendons, and ftdcr_v4_mujoco_base_selected/,
ftdcr_v4_mujoco_backbone_selected/ with gravity: the rows in order with their recorded timing, as
the fit). Aligned errors: the whole set's mean offset
removed (as the headline number), then split by family or by deflection (the distance of the
measured tip from the model's straight-pose tip, mm). Writes OUT_FILE_STEM.json and .md (default
docs/figures/calibration/ftdcr_v4_patterns).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from cdcr_gym.calibration import Measurements, read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.report import load_fitted
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params import RobotParams
from cdcr_gym.model.params_yaml import load_yaml

sys.path.insert(0, str(Path(__file__).parent))
from ftdcr_v4_ccka_selection import family  # noqa: E402

DATA = Path("data/real/ftdcr_v4")
FIG = Path("docs/figures/calibration")
FITS = {
    "CCKA, rigid base (ftdcr_v4_ccka)": FIG / "ftdcr_v4_ccka",
    "CCKA, compliant base (ftdcr_v4_ccka_base)": FIG / "ftdcr_v4_ccka_base",
    "CCKA, parallel tendons: compliant base, drive backlash (ftdcr_v4_ccka_selected)": FIG
    / "ftdcr_v4_ccka_selected",
    "CCKA, selected: the same with helically wound tendons (ftdcr_v4_ccka_helix)": FIG
    / "ftdcr_v4_ccka_helix",
    "CCKA, parallel tendons + drive softening (ftdcr_v4_ccka_softening)": FIG
    / "ftdcr_v4_ccka_softening",
    "MuJoCo, parallel tendons: no gravity, compliant base, drive backlash, backbone friction "
    "(ftdcr_v4_mujoco_selected)": FIG / "ftdcr_v4_mujoco_selected",
    "MuJoCo, selected: the same from the helical CCKA fit (ftdcr_v4_mujoco_helix)": FIG
    / "ftdcr_v4_mujoco_helix",
    "MuJoCo A: gravity, payload, compliant base, drive backlash (ftdcr_v4_mujoco_base_selected)": (
        FIG / "ftdcr_v4_mujoco_base_selected"
    ),
    "MuJoCo B: A + backbone friction (ftdcr_v4_mujoco_backbone_selected)": FIG
    / "ftdcr_v4_mujoco_backbone_selected",
    "MuJoCo, parallel tendons + drive softening (ftdcr_v4_mujoco_softening)": FIG
    / "ftdcr_v4_mujoco_softening",
    "MuJoCo, helical tendons + drive softening (ftdcr_v4_mujoco_helix_softening)": FIG
    / "ftdcr_v4_mujoco_helix_softening",
}
BINS_MM = (0.0, 20.0, 40.0, 60.0, np.inf)


def predict(folder: Path) -> tuple[np.ndarray, np.ndarray, Measurements]:
    """Held-out tips (M, 3) m of the fit in ``folder``, its straight-pose tip (3,) m, the data."""
    doc = load_yaml(folder / "params.yaml")
    cal = doc["calibration"]
    robot, backend = load_fitted(folder / "params.yaml")
    drive = TendonDrive.of(robot)
    if drive is None:
        raise ValueError(f"{folder}/params.yaml: no calibration.tendons")
    val = read_csv(DATA / "val.csv", robot=robot, drive=drive)
    values = {k: float(v) for k, v in cal["fitted"].items()}
    zero = Measurements(None, np.zeros((1, 3)), None, None, displacements=np.zeros((1, 9)))
    # the frame (and the drives' backlash and softening: kept beside the robot, in
    # calibration.tendons)
    frame = {
        k: v
        for k, v in values.items()
        if k.startswith(("base_", "marker")) or k in ("drive_backlash", "drive_softening")
    }
    straight = DriveReplay(zero, robot, drive)(frame).tip[0]
    if cal["backend"] == "ccka":  # the fitted robot carries the rest (angles, k, T0, E)
        return DriveReplay(val, robot, drive)(frame).tip, straight, val
    # the fit's backend arguments (the tilt is in the values: PhysicsReplay turns gravity)
    kwargs = {k: v for k, v in backend.items() if k != "base_orientation"}
    return PhysicsReplay(val, robot, drive, "mujoco", kwargs)(values).tip, straight, val


def beyond_training_commands() -> tuple[np.ndarray, dict]:
    """(M,) bool over val.csv's rows: a command outside that tendon's range over train.csv; and
    the two files' per-tendon ranges (mm, tendon order) with the beyond rows per family."""
    robot = RobotParams.preset("ftdcr_v4")
    drive = TendonDrive.of(robot)
    d = {
        n: read_csv(DATA / f"{n}.csv", robot=robot, drive=drive).displacements
        for n in ("train", "val")
    }
    if d["train"] is None or d["val"] is None:  # pragma: no cover - displacement files
        raise ValueError("train.csv and val.csv must hold displacement commands")
    low, high = d["train"].min(axis=0), d["train"].max(axis=0)
    beyond = ((d["val"] < low) | (d["val"] > high)).any(axis=1)
    ranges: dict = {
        f"{n}_mm": {
            "min": (x.min(axis=0) * 1e3).round(2).tolist(),
            "max": (x.max(axis=0) * 1e3).round(2).tolist(),
        }
        for n, x in d.items()
    }
    labels = read_csv(DATA / "val.csv", robot=robot, drive=drive).labels
    fam = np.array([family(lab) for lab in labels])
    ranges["beyond_rows_per_family"] = {
        f: int((beyond & (fam == f)).sum()) for f in ("same", "scurve", "spiral")
    }
    return beyond, ranges


def stats(aligned: np.ndarray, plain: np.ndarray) -> dict:
    return {
        "rows": int(len(aligned)),
        "rmse_aligned_mm": float(np.sqrt(np.mean(np.sum(aligned**2, axis=1))) * 1e3),
        "rmse_aligned_xyz_mm": [float(v) for v in np.sqrt(np.mean(aligned**2, axis=0)) * 1e3],
        "mean_mm": float(np.mean(np.linalg.norm(plain, axis=1)) * 1e3),
    }


def stiffness_sweep(folder: Path) -> list[dict]:
    """The CCKA fit in ``folder`` with the rod stiffness E scaled (its k, T0, frame kept):
    training and held-out aligned RMSE (mm) per factor — a diagnosis (it looks at val.csv), not a
    fit."""
    robot, _ = load_fitted(folder / "params.yaml")
    drive = TendonDrive.of(robot)
    fitted = load_yaml(folder / "params.yaml")["calibration"]["fitted"]
    # the fitted robot carries E, k, T0 and the tendon angles; the frame is applied on top
    values = {k: float(v) for k, v in fitted.items() if k.startswith(("base_", "marker"))}
    sets = {n: read_csv(DATA / f"{n}.csv", robot=robot, drive=drive) for n in ("train", "val")}
    out = []
    for factor in (1.0, 1.1, 1.2, 1.3, 1.4, 1.6):
        v = {**values, "youngs_modulus": factor * robot.youngs_modulus}
        row = {"E_factor": factor, "E_GPa": factor * robot.youngs_modulus / 1e9}
        for n, d in sets.items():
            err = DriveReplay(d, robot, drive)(v).tip - d.tip
            a = err - err.mean(axis=0)
            row[f"{n}_rmse_aligned_mm"] = float(np.sqrt(np.mean(np.sum(a**2, axis=1))) * 1e3)
        out.append(row)
    return out


def cell(s: dict) -> str:
    """A table cell: aligned RMSE (X / Y / Z; rows), mm."""
    xyz = " / ".join(f"{v:.1f}" for v in s["rmse_aligned_xyz_mm"])
    return f"{s['rmse_aligned_mm']:.2f} ({xyz}; {s['rows']} rows)"


def main(stem: Path) -> None:
    doc: dict = {}
    beyond, ranges = beyond_training_commands()
    for name, folder in FITS.items():
        if not (folder / "params.yaml").is_file():
            continue
        tip, straight, val = predict(folder)
        err = tip - val.tip
        aligned = err - err.mean(axis=0)
        fam = np.array([family(lab) for lab in val.labels])
        defl = np.linalg.norm(val.tip - straight, axis=1) * 1e3
        out: dict = {"all": stats(aligned, err), "family": {}, "deflection_mm": {}}
        out["commands"] = {
            "inside_training_range": stats(aligned[~beyond], err[~beyond]),
            "beyond_training_range": stats(aligned[beyond], err[beyond]),
        }
        for f in ("same", "scurve", "spiral"):
            m = fam == f
            out["family"][f] = stats(aligned[m], err[m])
        for lo, hi in zip(BINS_MM[:-1], BINS_MM[1:]):
            m = (defl >= lo) & (defl < hi)
            if m.any():
                out["deflection_mm"][f"{lo:g}-{hi:g}"] = stats(aligned[m], err[m])
        doc[name] = out
        print(name, json.dumps(out["family"]), flush=True)
    sweep = stiffness_sweep(FIG / "ftdcr_v4_ccka")
    stem.with_suffix(".json").write_text(
        json.dumps({"fits": doc, "command_ranges": ranges, "ccka_stiffness_sweep": sweep}, indent=1)
        + "\n"
    )
    lines = [
        "# FTDCR v4: held-out error by motion pattern and by deflection",
        "",
        "Aligned RMSE (mm; the whole held-out set's mean offset removed) and X / Y / Z.",
        "",
        "| model | all | same | scurve | spiral | "
        + " | ".join(f"deflection {k} mm" for k in next(iter(doc.values()))["deflection_mm"])
        + " |",
        "|---|---|---|---|---|" + "---|" * len(next(iter(doc.values()))["deflection_mm"]),
    ]
    for name, out in doc.items():
        lines.append(
            f"| {name} | {cell(out['all'])} | "
            + " | ".join(cell(out["family"][f]) for f in ("same", "scurve", "spiral"))
            + " | "
            + " | ".join(cell(s) for s in out["deflection_mm"].values())
            + " |"
        )
    lo, hi = np.array(ranges["train_mm"]["min"]), np.array(ranges["train_mm"]["max"])
    vlo, vhi = np.array(ranges["val_mm"]["min"]), np.array(ranges["val_mm"]["max"])
    lines += [
        "",
        f"Inside against beyond the training file's commands: {int(beyond.sum())} of "
        f"{beyond.size} held-out rows ("
        + ", ".join(f"{f} {n}" for f, n in ranges["beyond_rows_per_family"].items())
        + ") command a tendon outside that tendon's range over train.csv. Largest pull: "
        + ", ".join(
            f"tendon {i + 1} {hi[i]:.1f} mm in train, {vhi[i]:.1f} mm held out"
            for i in np.flatnonzero(vhi > hi)
        )
        + f"; largest release: {lo.min():.1f} mm in train, {vlo.min():.1f} mm held out. "
        "Aligned as the headline number (the whole set's offset removed), then split.",
        "",
        "| model | inside the training range | beyond it |",
        "|---|---|---|",
    ]
    for name, out in doc.items():
        c = out["commands"]
        lines.append(
            f"| {name} | {cell(c['inside_training_range'])} | {cell(c['beyond_training_range'])} |"
        )
    lines += [
        "",
        "The CCKA fit (`ftdcr_v4_ccka/`) with its rod stiffness E scaled, everything else kept "
        "(a diagnosis on the held-out rows, not a fit): aligned RMSE (mm).",
        "",
        "| E (GPa) | train | held-out |",
        "|---|---|---|",
    ]
    lines += [
        f"| {r['E_GPa']:.1f} | {r['train_rmse_aligned_mm']:.2f} | {r['val_rmse_aligned_mm']:.2f} |"
        for r in sweep
    ]
    lines += ["", "Command: `python configs/calibration/ftdcr_v4_patterns.py`", ""]
    stem.with_suffix(".md").write_text("\n".join(lines))


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else FIG / "ftdcr_v4_patterns")
