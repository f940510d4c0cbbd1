"""MuJoCo terms of the FTDCR v4 robot probed with the split of the structure selection: each
candidate (the base frame, the marker, E, the base compliance and the drive backlash, without
gravity, plus the probed names) fitted on the one-tendon and one-section rows of train.csv
and scored on its two-section rows, from the helical CCKA fit: the candidate step of
``configs/calibration/ftdcr_v4_mujoco_selection.py`` (its ``_candidate``), for names that
script does not list (docs/experiments/real_robot.md). val.csv is not read.

Usage: python -m experiments.ftdcr_v4_mujoco_probes [--terms backbone_friction+k_sections,...]
    [--out JSON]
(names joined by ``+``; 4–5 min per candidate without the capstan friction, 22–26 min with it,
two at a time)
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from experiments._config_script import load_script

SCRIPT = Path("configs/calibration/ftdcr_v4_mujoco_selection.py")
#: the probes of docs/experiments/real_robot.md: the tendon drive refitted per section on MuJoCo,
#: the cable–disk capstan friction beside the selected backbone friction or instead of it, and
#: the per-tendon pretensions refitted on MuJoCo
TERMS = [
    "backbone_friction+k_sections",
    "backbone_friction+T0_sections",
    "mu",
    "backbone_friction+mu",
    "backbone_friction+T0_tendons",
]


def _selection_module():
    return load_script(SCRIPT)


def candidates(terms: list[str]) -> dict[str, tuple[str, bool]]:
    """The selection script's candidates (name → (--fit list, gravity)) for ``terms``: its
    common names plus each term's names (joined by ``+``), without gravity."""
    common = _selection_module().COMMON
    out = {}
    for term in terms:
        names = [n for n in term.split("+") if n]
        if not names:
            raise ValueError(f"--terms: empty term in {terms!r}")
        out[term] = (",".join([common, *names]), False)
    return out


def _fit_one(item: tuple[str, tuple[str, bool]]) -> dict:
    return _selection_module()._candidate(item)


def run(terms: list[str]) -> dict[str, dict]:
    """Every term's row (the selection script's: fitted values, single and pair rows' aligned
    RMSE in mm, seconds), two fits at a time."""
    cands = candidates(terms)
    with ProcessPoolExecutor(2) as pool:
        return dict(zip(cands, pool.map(_fit_one, cands.items())))


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_mujoco_probes", description=__doc__.splitlines()[0]
    )
    p.add_argument("--terms", default=",".join(TERMS), help="comma-separated, names joined by +")
    p.add_argument("--out", type=Path, default=None, help="write the rows as JSON here")
    a = p.parse_args(argv)
    rows = run([t for t in a.terms.split(",") if t])
    for name, r in rows.items():
        print(
            f"{name}: single {r['selection_single_rmse_aligned_mm']:.3f}, pairs "
            f"{r['selection_pairs_rmse_aligned_mm']:.3f} mm; "
            + ", ".join(f"{k} {v:.4g}" for k, v in r["fitted_values"].items())
        )
    if a.out is not None:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps(rows, indent=1) + "\n")
        print("wrote", a.out)


if __name__ == "__main__":
    main()
