"""The CCKA selection step for the drive softening on the FTDCR v4 robot: the selected CCKA
parameter set (``E+T0_tendons+cable_angles+base_compliance+drive_backlash``) with and without
``drive_softening`` (started at 10 1/m: at 0 its gradient vanishes), each fitted on the
one-tendon and one-section rows of train.csv and scored on its two-section rows, then refitted on
all of train.csv and replayed on val.csv: the candidate step of
``configs/calibration/ftdcr_v4_ccka_selection.py`` (docs/experiments/real_robot.md).

Usage: python -m experiments.ftdcr_v4_softening_selection   (about 1 min)
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

from cdcr_gym.calibration import calibrate

SCRIPT = Path("configs/calibration/ftdcr_v4_ccka_selection.py")
SELECTED = "E,T0_tendons,cable_angles,base_compliance,drive_backlash"
#: the softening's start (1/m)
START = 10.0


def _selection_module():
    spec = importlib.util.spec_from_file_location("ftdcr_v4_ccka_selection", SCRIPT)
    if spec is None or spec.loader is None:  # pragma: no cover - the script is in the checkout
        raise ValueError(f"{SCRIPT}: not found (run from the checkout)")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run() -> dict[str, dict]:
    """The two candidates' rows (as the selection script's)."""
    module = _selection_module()

    def with_start(data, robot, names, *args, **kwargs):
        if "drive_softening" in names:
            kwargs.setdefault("start", {"drive_softening": START})
        return calibrate(data, robot, names, *args, **kwargs)

    module.calibrate = with_start
    out = {}
    for name, fit in (
        ("selected", SELECTED),
        ("selected+drive_softening", SELECTED + ",drive_softening"),
    ):
        row = module._candidate((name, fit))
        print(
            f"{name}: pairs {row['selection_pairs_rmse_aligned_mm']:.4f}, train "
            f"{row['train_rmse_aligned_mm']:.4f}, held-out {row['val_rmse_aligned_mm']:.4f} mm"
            + (
                f", σ = {row['fitted_values']['drive_softening']:.1f} 1/m"
                if "drive_softening" in row["fitted_values"]
                else ""
            ),
            flush=True,
        )
        out[name] = row
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_softening_selection",
        description=__doc__.splitlines()[0],
    )
    parser.parse_args(argv)
    run()


if __name__ == "__main__":
    main()
