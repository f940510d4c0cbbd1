"""The CCKA selection step for terms added to the selected set of the FTDCR v4 robot
(``E+T0_tendons+cable_angles+base_compliance+drive_backlash``): the set with and without each
addition (``--add``, default ``drive_softening``; several names joined by ``+``), each fitted on
the one-tendon and one-section rows of train.csv and scored on its two-section rows, then
refitted on all of train.csv and replayed on val.csv: the candidate step of
``configs/calibration/ftdcr_v4_ccka_selection.py`` (docs/experiments/real_robot.md). The
softening starts at 10 1/m (at 0 its gradient vanishes); every other added name at its robot
value.

Usage: python -m experiments.ftdcr_v4_term_selection [--add drive_softening,cable_pitch,...]
(about 30 s per candidate)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from cdcr_gym.calibration import calibrate
from experiments._config_script import load_script

SCRIPT = Path("configs/calibration/ftdcr_v4_ccka_selection.py")
SELECTED = "E,T0_tendons,cable_angles,base_compliance,drive_backlash"
#: the softening's start (1/m)
START = 10.0


def _selection_module():
    return load_script(SCRIPT)


def run(additions: list[str] | None = None) -> dict[str, dict]:
    """The candidates' rows (as the selection script's): the selected set, then the set with
    each addition (names joined by ``+``)."""
    additions = ["drive_softening"] if additions is None else additions
    module = _selection_module()

    def with_start(data, robot, names, *args, **kwargs):
        if "drive_softening" in names:
            kwargs.setdefault("start", {"drive_softening": START})
        return calibrate(data, robot, names, *args, **kwargs)

    module.calibrate = with_start
    out = {}
    candidates = [("selected", SELECTED)] + [
        (f"selected+{add}", SELECTED + "," + add.replace("+", ",")) for add in additions
    ]
    for name, fit in candidates:
        row = module._candidate((name, fit))
        added = [n for n in row["fitted_values"] if n in fit.split(",")[5:] or "+" + n in name]
        extra = ", ".join(f"{n} = {row['fitted_values'][n]:.4g}" for n in added)
        print(
            f"{name}: pairs {row['selection_pairs_rmse_aligned_mm']:.4f}, train "
            f"{row['train_rmse_aligned_mm']:.4f}, held-out {row['val_rmse_aligned_mm']:.4f} mm"
            + (f" ({extra}, SI)" if extra else ""),
            flush=True,
        )
        out[name] = row
    return out


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_term_selection", description=__doc__.splitlines()[0]
    )
    parser.add_argument(
        "--add",
        default="drive_softening",
        help="comma-separated additions to the selected set (names of one addition joined by +)",
    )
    args = parser.parse_args(argv)
    run([a.strip() for a in args.add.split(",") if a.strip()])


if __name__ == "__main__":
    main()
