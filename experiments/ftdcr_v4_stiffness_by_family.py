"""How stiff each motion family of the FTDCR v4 files looks to a CCKA fit: a diagnosis
of the held-out error, not a fit (docs/experiments/real_robot.md).

For every pattern family of train.csv and val.csv (``seg1``, ``pair12_same``, ``all3_same``, …;
the label without its repetition, direction and hold tags), the CCKA fit with parallel tendons
(``ftdcr_v4_ccka_selected``) is replayed with its rod's Young's modulus E scaled by one factor,
everything else kept, and that factor is fitted by least squares to the family's tip positions
(aligned: the family's own mean offset removed). A family whose apparent E* lies above the fit's
bends less than the model predicts from its commands; below, more. Families with fewer than
``MIN_ROWS`` rows are skipped.

Then the same refit of the probe model's common parameters (frame, marker, E, base compliance) on
val.csv itself, which bounds what any refit of those parameters could reach on the held-out rows.

Usage: python -m experiments.ftdcr_v4_stiffness_by_family   (about 30 s)
"""

from __future__ import annotations

import re
from collections.abc import Callable

import numpy as np
from scipy.optimize import least_squares

from cdcr_gym.calibration import Measurements, read_csv
from experiments.ftdcr_v4_structure_probes import DATA, Probe, rmse_aligned, selected_fit

#: the smallest family fitted
MIN_ROWS = 30


def family(label: str) -> str:
    """The motion family of a row label: ``rep1_pair12_same_dir60_hold`` → ``pair12_same``,
    ``rep1_tendon4_id2_pull`` → ``tendon4``, ``rep1_seg2_circle`` → ``seg2``."""
    text = re.sub(r"^rep\d+_", "", label)
    text = re.sub(r"_id\d+.*$", "", text)
    return re.sub(r"_(dir\d+|hold|circle|pull).*$", "", text)


def apparent_modulus(probe: Probe, data: Measurements) -> tuple[float, float, float]:
    """``(E* Pa, aligned RMSE at the fit's E mm, aligned RMSE at E* mm)`` of ``data``: E scaled
    by exp(x), x fitted, every other parameter of ``probe`` at its start."""

    def residual(x: np.ndarray) -> np.ndarray:
        p = np.zeros(probe.size)
        p[7] = x[0]  # ln(E/E₀): the probe's common parameter 7
        e = (probe(data, p) - data.tip) * 1e3
        return (e - e.mean(axis=0)).ravel()

    fit = least_squares(residual, [0.0], diff_step=1e-3)
    rows = len(data.tip)
    before = float(np.sqrt(np.sum(residual(np.zeros(1)) ** 2) / rows))
    after = float(np.sqrt(np.sum(fit.fun**2) / rows))
    return probe.robot.youngs_modulus * float(np.exp(fit.x[0])), before, after


def run(report: Callable[[str], None] = print) -> dict:
    """E* per family of both files, then the common refit on val.csv (module docstring)."""
    robot, drive, values = selected_fit()
    probe = Probe("isotropic", robot, drive, values)
    out: dict = {"fit_E_GPa": robot.youngs_modulus / 1e9, "families": {}}
    report(f"the fit's E: {robot.youngs_modulus / 1e9:.1f} GPa")
    sets = {}
    for name in ("train", "val"):
        data = read_csv(DATA / f"{name}.csv", robot=robot, drive=drive)
        sets[name] = data
        families = np.array([family(lab) for lab in data.labels])
        for fam in dict.fromkeys(families):
            idx = np.flatnonzero(families == fam)
            if len(idx) < MIN_ROWS:
                continue
            e_star, before, after = apparent_modulus(probe, data.subset(idx))
            out["families"][f"{name}/{fam}"] = {
                "rows": len(idx),
                "E_star_GPa": e_star / 1e9,
                "rmse_aligned_mm": before,
                "rmse_aligned_at_E_star_mm": after,
            }
            report(
                f"{name:5s} {fam:12s} {len(idx):4d} rows: E* {e_star / 1e9:5.1f} GPa, "
                f"aligned RMSE {before:.2f} → {after:.2f} mm"
            )
    p = probe.fit(sets["val"])
    out["val_refit"] = {
        "val_rmse_aligned_mm": rmse_aligned(probe(sets["val"], p), sets["val"].tip),
        "train_rmse_aligned_mm": rmse_aligned(probe(sets["train"], p), sets["train"].tip),
        "E_GPa": robot.youngs_modulus * float(np.exp(p[7])) / 1e9,
    }
    r = out["val_refit"]
    report(
        f"frame, marker, E and base compliance refitted on val.csv: held-out "
        f"{r['val_rmse_aligned_mm']:.3f} mm (train with them {r['train_rmse_aligned_mm']:.3f} "
        f"mm), E {r['E_GPa']:.1f} GPa"
    )
    return out


def main(argv: list[str] | None = None) -> None:
    import argparse

    argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_stiffness_by_family",
        description=__doc__.splitlines()[0],
    ).parse_args(argv)
    run()


if __name__ == "__main__":
    main()
