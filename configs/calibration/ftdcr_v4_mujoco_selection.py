"""Which error sources of the MuJoCo model of the FTDCR v4 robot generalise to other motion
patterns: the model structure chosen on the training file only, with the split of the CCKA
selection (configs/calibration/ftdcr_v4_ccka_selection.py).

Usage (after configs/calibration/ftdcr_v4_ccka.sh):
    python configs/calibration/ftdcr_v4_mujoco_selection.py [OUT_DIR [START]]

Every candidate is a MuJoCo fit (the rows in order with their recorded timing, gaps capped at
1 s, 0.04 s steps, at most MAX_EVALS optimiser steps) of the base frame, the marker offset, E,
the base compliance and the drive backlash, started from the selected CCKA fit
(START, default ``ftdcr_v4_ccka_helix/params.yaml``: its geometry, pretensions and values;
the round before the helical routing started from ``ftdcr_v4_ccka_selected/params.yaml`` and
wrote ``ftdcr_v4_mujoco_selection/``), with or without gravity
(and then a fitted tip payload), with or without backbone friction, and without gravity with or
without a drive softening (``drive_softening``, from 10 1/m). It is fitted on the
training rows that move ONE tendon or ONE section and scored on the training rows that move TWO
sections (``pair*``); the candidate with the lowest aligned RMSE on the pair rows is the
structure of the main MuJoCo fit (configs/calibration/ftdcr_v4_mujoco.sh). val.csv is not read.

Writes OUT_DIR/selection.json and OUT_DIR/selection.md (default
docs/figures/calibration/ftdcr_v4_mujoco_selection_helix).
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from ftdcr_v4_ccka_selection import family, select  # noqa: E402

from cdcr_gym.calibration import calibrate, read_csv  # noqa: E402
from cdcr_gym.calibration.drive import TendonDrive  # noqa: E402
from cdcr_gym.calibration.parameters import expand_names  # noqa: E402
from cdcr_gym.calibration.report import error_stats  # noqa: E402
from cdcr_gym.model.params import RobotParams  # noqa: E402
from cdcr_gym.model.params_yaml import load_yaml  # noqa: E402

DATA = Path("data/real/ftdcr_v4")
START = Path("docs/figures/calibration/ftdcr_v4_ccka_helix/params.yaml")
MAX_EVALS = 4
TIMING = {"physics_timestep": 0.04, "control_timestep": 0.04}
COMMON = "base_frame,marker,E,base_compliance,drive_backlash"
#: the start of the backbone friction (N·m), as the main fit's
FRICTION_START = 0.001
#: the start of the drive softening (1/m: d_s = 100 mm; at 0 its gradient vanishes)
SOFTENING_START = 10.0
#: the start of the cable–disk capstan μ (the CCKA fit has none)
MU_START = 0.05
#: the starts of the names a CCKA fit does not give (the rest start at the CCKA fit's values)
STARTS = {
    "backbone_friction": FRICTION_START,
    "drive_softening": SOFTENING_START,
    "friction_coefficient": MU_START,
}

#: name → (--fit list, gravity)
CANDIDATES: dict[str, tuple[str, bool]] = {
    "gravity+payload": (f"{COMMON},payload", True),
    "gravity+payload+backbone_friction": (f"{COMMON},payload,backbone_friction", True),
    "no_gravity": (COMMON, False),
    "no_gravity+backbone_friction": (f"{COMMON},backbone_friction", False),
    "no_gravity+drive_softening": (f"{COMMON},drive_softening", False),
    "no_gravity+backbone_friction+drive_softening": (
        f"{COMMON},backbone_friction,drive_softening",
        False,
    ),
}


def _robot_and_drive(start: Path) -> tuple[RobotParams, TendonDrive]:
    """The CCKA fit's robot and tendon drive (with its backlash) of the file ``start``."""
    robot = RobotParams.from_yaml(start)
    drive = TendonDrive.of(robot)
    if drive is None:
        raise ValueError(f"{start}: no tendon drive")
    kept = TendonDrive.from_dict(
        load_yaml(start)["calibration"]["tendons"], robot.n_cables, f"{start}: tendons"
    )
    return robot, replace(drive, backlash=kept.backlash, max_tension=kept.max_tension)


def _candidate(item: tuple[str, tuple[str, bool]], start_from: Path = START) -> dict:
    """Fit one candidate on the single rows, score it on the pair rows (module docstring),
    started from the CCKA fit ``start_from``."""
    name, (fit, gravity) = item
    robot, drive = _robot_and_drive(start_from)
    train = read_csv(DATA / "train.csv", robot=robot, drive=drive)
    pair = np.array([family(lab).startswith("pair") for lab in train.labels])
    single, pairs = train.subset(np.flatnonzero(~pair)), train.subset(np.flatnonzero(pair))
    fitted = load_yaml(start_from)["calibration"]["fitted"]
    wanted = set(expand_names(fit, robot))
    start = {k: float(v) for k, v in fitted.items() if k in wanted}
    start.update({k: v for k, v in STARTS.items() if k in wanted})
    t0 = time.perf_counter()
    res = calibrate(
        single,
        robot,
        fit,
        "mujoco",
        {**TIMING, "gravity": gravity},
        start,
        max_nfev=MAX_EVALS,
        drive=drive,
        validate=pairs,
        replay_options={"max_gap": 1.0},
    )
    if res.validation is None:  # pragma: no cover - validate given
        raise RuntimeError("the fit ran without its validation replay")
    r = {
        "fit": fit,
        "gravity": gravity,
        "fitted": len(res.names),
        "selection_single_rmse_aligned_mm": error_stats(res.after.tip, single.tip)[
            "rmse_aligned_mm"
        ],
        "selection_pairs_rmse_aligned_mm": error_stats(res.validation.tip, pairs.tip)[
            "rmse_aligned_mm"
        ],
        "fitted_values": {n: float(res.values[n]) for n in res.names},
        "seconds": round(time.perf_counter() - t0, 1),
    }
    print(
        f"{name}: single {r['selection_single_rmse_aligned_mm']:.2f}, pairs "
        f"{r['selection_pairs_rmse_aligned_mm']:.2f} mm ({r['seconds']:.0f} s)",
        flush=True,
    )
    return r


def main(out: Path, start_from: Path = START) -> None:
    rows, best = select(
        CANDIDATES,
        partial(_candidate, start_from=start_from),
        "MuJoCo fits on the one-tendon/one-section rows of train.csv, the lowest aligned "
        "RMSE on its two-section (pair) rows selected; val.csv not used",
        out,
    )
    lines = [
        "# MuJoCo model selection (FTDCR v4)",
        "",
        "MuJoCo fits (base frame, marker, E, base compliance, drive backlash; "
        f"{MAX_EVALS} optimiser steps from the CCKA fit `{start_from}`) on the one-tendon and "
        "one-section rows of train.csv, scored on its two-section rows (`pair*`): the "
        f"candidate with the lowest aligned RMSE there is selected (**{best}**). The held-out "
        "file is not read. Aligned RMSE in mm.",
        "",
        "| candidate | gravity | fitted | single rows (fit) | pair rows (selection) | s |",
        "|---|---|---|---|---|---|",
    ]
    for name, r in rows.items():
        lines.append(
            f"| {name}{' (selected)' if name == best else ''} | "
            f"{'on' if r['gravity'] else 'off'} | {r['fitted']} | "
            f"{r['selection_single_rmse_aligned_mm']:.2f} | "
            f"{r['selection_pairs_rmse_aligned_mm']:.2f} | {r['seconds']:.0f} |"
        )
    lines += [
        "",
        f"Command: `python configs/calibration/ftdcr_v4_mujoco_selection.py {out} {start_from}`",
        "",
    ]
    (out / "selection.md").write_text("\n".join(lines))
    print("selected:", best)


if __name__ == "__main__":
    main(
        Path(sys.argv[1])
        if len(sys.argv) > 1
        else Path("docs/figures/calibration/ftdcr_v4_mujoco_selection_helix"),
        Path(sys.argv[2]) if len(sys.argv) > 2 else START,
    )
