"""What each error source is worth for the MuJoCo model of the FTDCR v4 robot: one REFIT per
error source removed (or, for gravity, switched), scored on the held-out rows (val.csv), beside
the pybullet replay of the fitted robot and the constant-curvature model of the same robot.

Usage (after configs/calibration/ftdcr_v4_mujoco.sh):
    python configs/calibration/ftdcr_v4_mujoco_ablation.py [FULL_DIR] [--table-only] [--jobs N]
        [--only rigid_base,no_backbone_friction,...]

FULL_DIR is the full model's fit (default docs/figures/calibration/ftdcr_v4_mujoco_helix:
the structure chosen on train.csv by configs/calibration/ftdcr_v4_mujoco_selection.py —
compliant one-sided tendons, a compliant base, backbone friction, drive backlash, no gravity,
helically wound tendons; a drive softening where the full fit has one, with a variant without
it; a variant with parallel tendons where the full fit's are helical).
Every variant is a `cdcr-gym calibrate` run on train.csv (MuJoCo, rows in order with their
recorded timing, gaps capped at 1 s) warm-started from the full fit with ONE thing changed, at
most MAX_EVALS optimiser steps, two runs at a time; each refits what the full fit fitted (the
frame, the marker, E, the base compliance, the backbone friction, the drive backlash) less what
the variant removes, with the full fit's gravity setting. The gravity variant is the other
setting: without gravity when the full fit has it (the payload then goes too), with gravity and
a fitted tip payload when it has not. The parallel-tendon variant sets the pitch to zero and
keeps the tendon angles and pretensions of the helical CCKA fit (it removes the helix, not
the CCKA refit that came with it). The CCKA row of the table is the CCKA fit the full fit
started from (its ``--start-from``). Writes FULL_DIR/ablation/<variant>/ (each run's report)
and FULL_DIR/ablation.json, FULL_DIR/ablation.md.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from cdcr_gym.calibration import read_csv
from cdcr_gym.calibration.drive import TendonDrive
from cdcr_gym.calibration.physics import PhysicsReplay
from cdcr_gym.calibration.report import backend_kwargs_from_yaml, error_stats, load_fitted
from cdcr_gym.calibration.simulate import DriveReplay
from cdcr_gym.model.params_yaml import load_yaml
from cdcr_gym.model.yaml_io import dump_yaml

DATA = Path("data/real/ftdcr_v4")
FIG = Path("docs/figures/calibration")
TIMING = ["--backend-arg", "physics_timestep=0.04", "--backend-arg", "control_timestep=0.04"]
MAX_EVALS = 2
#: the stiffest tendons MuJoCo integrates stably at the 0.04 s step (x100 diverges)
RIGID_SCALE = 10.0
#: what the full fit fits (and ``drive_softening`` where the full fit has it: :func:`full_fit`)
FULL_FIT = ["base_frame", "marker", "E", "base_compliance", "backbone_friction", "drive_backlash"]
#: the variant of a full fit with a drive softening
NO_SOFTENING = ("no drive softening", [], ["drive_softening"], {})
#: the variant of a full fit with helically wound tendons
PARALLEL = ("parallel tendons (no helix)", [], [], {"cable_pitch": 0.0})

#: variant → (what, extra arguments, names removed from FULL_FIT, robot fields overridden)
VARIANTS: dict[str, tuple[str, list[str], list[str], dict[str, float]]] = {
    "no_backlash": ("no drive backlash", [], ["drive_backlash"], {}),
    "no_backbone_friction": ("no backbone friction", [], ["backbone_friction"], {}),
    "rigid_base": (
        "rigid base (no base compliance)",
        [],
        ["base_compliance"],
        {"base_compliance": 0.0},
    ),
    "rigid_tendons": (
        f"rigid tendons (every k x {RIGID_SCALE:g}, k not fitted)",
        ["--stiffness-scale", f"{RIGID_SCALE:g}"],
        [],
        {},
    ),
    "no_slack": ("no slack: the linear law, tendons push", ["--linear-law"], [], {}),
    "no_base_frame": (
        "no base-frame fit (robot base = measurement frame)",
        [],
        ["base_frame"],
        {},
    ),
}

#: the gravity variant: (name, what, extra arguments, names added to FULL_FIT) for a full fit
#: with gravity (True) and without (False)
GRAVITY_VARIANT: dict[bool, tuple[str, str, list[str], list[str]]] = {
    True: ("no_gravity", "no gravity (and so no payload)", ["--backend-arg", "gravity=false"], []),
    False: (
        "gravity",
        "with gravity and a fitted tip payload",
        ["--backend-arg", "gravity=true"],
        ["payload"],
    ),
}

#: the paper's numbers (CCKA vs physics, CCKA vs measurements, the published MuJoCo model), %
PAPER = {"ccka_vs_physics": 0.77, "ccka_vs_measurements": 0.37, "published_mujoco": 4.1}


def _fitted(folder: Path) -> dict[str, float]:
    return {
        k: float(v) for k, v in load_yaml(folder / "params.yaml")["calibration"]["fitted"].items()
    }


def _backend(folder: Path) -> dict:
    """The fit's backend arguments (``backend:`` of its params.yaml)."""
    return backend_kwargs_from_yaml(folder / "params.yaml")


def _gravity(full: Path) -> bool:
    """Whether the full fit simulated gravity (the CLI's default: on)."""
    return bool(_backend(full).get("gravity", True))


def full_fit(full: Path) -> list[str]:
    """What the full fit in ``full`` fitted: FULL_FIT, and its drive softening if it has one."""
    fitted = (load_yaml(full / "params.yaml").get("calibration") or {}).get("fitted") or {}
    return FULL_FIT + (["drive_softening"] if "drive_softening" in fitted else [])


def variants(
    full: Path,
) -> dict[str, tuple[str, list[str], list[str], dict[str, float], list[str]]]:
    """The variants of ``full``: name → (what, extra arguments, names removed from its fit,
    robot fields overridden, names added to its fit); the gravity variant follows the full
    fit's setting (module docstring), the drive softening's where it has one."""
    out = {n: (*v, []) for n, v in VARIANTS.items()}
    if "drive_softening" in full_fit(full):
        out["no_softening"] = (*NO_SOFTENING, [])
    robot = load_yaml(full / "params.yaml").get("robot") or {}
    if float(robot.get("cable_pitch", 0.0)) != 0.0:
        out["parallel_tendons"] = (*PARALLEL, [])
    name, what, extra, added = GRAVITY_VARIANT[_gravity(full)]
    out[name] = (what, extra, [], {}, added)
    return out


def ccka_start(full: Path) -> Path:
    """The CCKA fit the full fit started from: the folder of its command's ``--start-from``."""
    command = (load_yaml(full / "params.yaml").get("calibration") or {}).get("command", "")
    words = shlex.split(command)
    if "--start-from" not in words:
        raise ValueError(f"{full / 'params.yaml'}: calibration.command has no --start-from")
    return Path(words[words.index("--start-from") + 1]).parent


def refit(full: Path, name: str) -> None:
    """One ablation refit (module docstring), warm-started from ``full``."""
    _, extra, removed, override, added = variants(full)[name]
    folder = full / "ablation" / name
    folder.mkdir(parents=True, exist_ok=True)
    robot = full / "params.yaml"
    # the full robot with fields changed, as a params YAML of its own (only its robot: without
    # the fitted drive's backlash and softening, kept in calibration.tendons, unless the
    # variant fits them)
    if override or {"drive_backlash", "drive_softening"} & set(removed):
        doc = load_yaml(robot)
        doc["robot"].update(override)
        robot = folder.parent / f"{name}_robot.yaml"
        robot.write_text(dump_yaml({"robot": doc["robot"]}))
    values = _fitted(full)
    fixed = []  # backbone friction: fitted from the full fit's value, or off (the default)
    if _gravity(full) and "gravity=false" not in extra:
        fixed += ["--backend-arg", f"tip_payload={_backend(full).get('tip_payload', 0.0)!r}"]
    elif not _gravity(full) and "gravity=true" not in extra:
        fixed += ["--backend-arg", "gravity=false"]
    fit = [n for n in full_fit(full) if n not in removed] + added
    starts = []
    if "backbone_friction" in fit:
        starts = ["--start", f"backbone_friction={values['backbone_friction']!r}"]
    cmd = [
        sys.executable,
        "-m",
        "training.studies.calibrate",
        str(DATA / "train.csv"),
        "--robot",
        str(robot),
        "--backend",
        "mujoco",
        "--validate",
        str(DATA / "val.csv"),
        "--fit",
        ",".join(fit),
        "--start-from",
        str(full / "params.yaml"),
        *starts,
        *TIMING,
        *fixed,
        "--max-gap",
        "1.0",
        "--max-evals",
        str(MAX_EVALS),
        "--quiet",
        *extra,
        "--out",
        str(folder),
    ]
    t0 = time.perf_counter()
    log = full / "ablation" / f"{name}.log"
    with log.open("w") as fh:
        subprocess.run(cmd, check=True, stdout=fh, stderr=subprocess.STDOUT)
    print(f"{name}: {time.perf_counter() - t0:.0f} s", flush=True)


def record(folder: Path, what: str) -> dict:
    """The held-out numbers of the fit in ``folder`` (its params.yaml and report.json)."""
    doc = load_yaml(folder / "params.yaml")
    cal = doc["calibration"]
    val = cal["validation"]
    length = sum(s["length"] for s in doc["robot"]["sections"])
    rep = json.loads((folder / "report.json").read_text())
    return {
        "what": what,
        "fitted": len(cal["fitted"]),
        "rmse_aligned_mm": val["rmse_aligned_mm"],
        "rmse_aligned_xyz_mm": val["rmse_aligned_xyz_mm"],
        "mean_mm": val["mean_mm"],
        "percent_of_length": 100.0 * val["mean_mm"] * 1e-3 / length,
        "train_rmse_aligned_mm": rep["train"]["rmse_aligned_mm"],
        "seconds": round(float(rep["seconds"]), 1),
        "command": cal.get("command", ""),
    }


def replays(full: Path) -> tuple[dict, dict, dict]:
    """The pybullet replay of the full fit (no backbone friction: a MuJoCo term), the CCKA model
    of the same robot and its distance to the MuJoCo replay without gravity and friction (no
    refits)."""
    params_yaml = full / "params.yaml"
    robot, backend = load_fitted(params_yaml)
    values = _fitted(full)
    payload = float(backend.get("tip_payload", 0.0))
    drive = TendonDrive.of(robot)
    if drive is None:
        raise ValueError(f"{params_yaml}: no tendon drive (calibration.tendons)")
    val = read_csv(DATA / "val.csv", robot=robot, drive=drive)
    plain = {k: v for k, v in values.items() if k not in ("backbone_friction", "tip_payload")}

    def row(what: str, tip: np.ndarray, seconds: float) -> dict:
        s = error_stats(tip, val.tip)
        return {
            "what": what,
            "fitted": 0,
            "rmse_aligned_mm": s["rmse_aligned_mm"],
            "rmse_aligned_xyz_mm": s["rmse_aligned_xyz_mm"],
            "mean_mm": s["mean_mm"],
            "percent_of_length": 100.0 * s["mean_mm"] * 1e-3 / robot.length,
            "seconds": round(seconds, 1),
        }

    t0 = time.perf_counter()
    gravity = bool(backend.get("gravity", True))
    bullet_kw = {"gravity": gravity, "tip_payload": payload} if gravity else {"gravity": False}
    bullet = PhysicsReplay(val, robot, drive, "bullet", bullet_kw)
    b_row = row(
        "pybullet replay of the MuJoCo-fitted robot (no backbone friction, not refitted)",
        bullet(plain).tip,
        time.perf_counter() - t0,
    )
    t0 = time.perf_counter()
    timing = {"physics_timestep": 0.04, "control_timestep": 0.04}
    nograv = PhysicsReplay(val, robot, drive, "mujoco", {"gravity": False, **timing})
    mj = nograv(plain).tip
    ccka = DriveReplay(val, robot, drive)(plain).tip
    c_row = row(
        "CCKA of the same robot (no gravity, no friction; not refitted)",
        ccka,
        time.perf_counter() - t0,
    )
    dist = np.linalg.norm(ccka - mj, axis=1) * 1e3
    cc = {
        "mean_mm": float(dist.mean()),
        "median_mm": float(np.median(dist)),
        "p95_mm": float(np.percentile(dist, 95)),
        "percent_of_length": float(100.0 * dist.mean() * 1e-3 / robot.length),
    }
    return b_row, c_row, cc


def table(full: Path) -> None:
    weight = "gravity, payload" if _gravity(full) else "no gravity"
    rows = {
        "full": record(
            full,
            f"MuJoCo, full: {weight}, compliant one-sided tendons, compliant base, "
            "backbone friction, drive backlash"
            + (", drive softening" if "drive_softening" in full_fit(full) else "")
            + (", helical tendons" if "parallel_tendons" in variants(full) else ""),
        )
    }
    for name, (what, *_) in variants(full).items():
        folder = full / "ablation" / name
        if (folder / "params.yaml").is_file():
            rows[name] = record(folder, what)
    b_row, c_row, cc = replays(full)
    rows["bullet"] = b_row
    rows["ccka_same_robot"] = c_row
    ccka_fit = json.loads((ccka_start(full) / "report.json").read_text())["validation"]
    doc = {
        "rows": rows,
        "ccka_vs_mujoco_no_gravity": cc,
        "ccka_fit_vs_measurements_percent_of_length": ccka_fit["percent_of_length"],
        "paper_percent_of_length": PAPER,
        "refit_max_evals": MAX_EVALS,
    }
    (full / "ablation.json").write_text(json.dumps(doc, indent=1) + "\n")
    lines = [
        "# MuJoCo ablation on the held-out rows (val.csv)",
        "",
        "Each variant is refitted on train.csv with one error source removed (warm-started from "
        f"the full fit, at most {MAX_EVALS} optimiser steps), then replayed on the held-out "
        "rows. Aligned RMSE: Euclidean tip RMSE after removing the mean offset (mm); X / Y / Z "
        "its components; mean: plain mean tip error (mm); % of length: the mean over the "
        "robot's length; train: the training rows' aligned RMSE; fitted: parameters refitted.",
        "",
        "| variant | fitted | aligned RMSE | X / Y / Z | mean | % of length | train | wall time (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows.values():
        xyz = " / ".join(f"{v:.2f}" for v in r["rmse_aligned_xyz_mm"])
        train = f"{r['train_rmse_aligned_mm']:.2f}" if "train_rmse_aligned_mm" in r else "-"
        lines.append(
            f"| {r['what']} | {r['fitted']} | {r['rmse_aligned_mm']:.2f} | {xyz} | "
            f"{r['mean_mm']:.2f} | {r['percent_of_length']:.2f} | {train} | {r['seconds']:.0f} |"
        )
    lines += [
        "",
        "Beside the paper (mean tip error in % of the robot's length):",
        "",
        "| comparison | here | paper |",
        "|---|---|---|",
        f"| CCKA vs the physics model (same robot, no gravity) | {cc['percent_of_length']:.2f} | "
        f"{PAPER['ccka_vs_physics']:.2f} |",
        f"| CCKA fit vs measurements (held-out; `{ccka_start(full).name}`) | "
        f"{ccka_fit['percent_of_length']:.2f} | "
        f"{PAPER['ccka_vs_measurements']:.2f} |",
        f"| MuJoCo fit vs measurements (held-out) | {rows['full']['percent_of_length']:.2f} | "
        f"{PAPER['published_mujoco']:.1f} (the published model) |",
        "",
        f"CCKA against MuJoCo without gravity: mean tip distance {cc['mean_mm']:.2f} mm, median "
        f"{cc['median_mm']:.2f} mm, 95th percentile {cc['p95_mm']:.2f} mm.",
        "",
        f"Command: `python configs/calibration/ftdcr_v4_mujoco_ablation.py {full}`; each "
        "refit's command is in its params.yaml and in ablation.json.",
        "",
    ]
    (full / "ablation.md").write_text("\n".join(lines))


def main(
    full: Path, table_only: bool = False, jobs: int = 2, only: list[str] | None = None
) -> None:
    if not table_only:
        names = only or list(variants(full))
        with ThreadPoolExecutor(jobs) as pool:  # refits at once (2 cores: 2)
            list(pool.map(lambda n: refit(full, n), names))
    table(full)


if __name__ == "__main__":
    import argparse

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("full", nargs="?", type=Path, default=FIG / "ftdcr_v4_mujoco_helix")
    p.add_argument("--table-only", action="store_true", help="collect the table, no refits")
    p.add_argument("--jobs", type=int, default=2, help="refits at once (default 2)")
    p.add_argument("--only", default="", help="comma-separated variants (module docstring)")
    a = p.parse_args()
    only = [n for n in a.only.split(",") if n]
    known = list(variants(a.full))
    for n in only:
        if n not in known:
            p.error(f"--only: unknown variant {n!r}; choose from {known}")
    if a.jobs < 1:
        p.error(f"--jobs must be >= 1, got {a.jobs}")
    main(a.full, a.table_only, a.jobs, only or None)
