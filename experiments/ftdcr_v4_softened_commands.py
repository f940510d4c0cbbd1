"""Copies of the FTDCR v4 measurement files whose pulls went through a drive softening, for
trying the term on a physics backend before it is built in (docs/experiments/real_robot.md):
every servo command y > 0 (mm) becomes ``d_s·tanh(y/d_s)``; released commands, timestamps,
labels and tips are copied unchanged.

Usage: python -m experiments.ftdcr_v4_softened_commands D_S_MM OUT_DIR
then calibrate on OUT_DIR/train.csv with ``--validate OUT_DIR/val.csv`` (the MuJoCo command of
configs/calibration/ftdcr_v4_mujoco.sh).
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

DATA = Path("data/real/ftdcr_v4")


def soften_file(source: Path, target: Path, d_s_mm: float) -> int:
    """Write ``source`` (the published format) to ``target`` with its ``servo_*_mm`` pulls
    softened by ``d_s_mm`` (mm, > 0); returns the number of rows."""
    if not (math.isfinite(d_s_mm) and d_s_mm > 0.0):
        raise ValueError(f"d_s_mm must be finite and > 0 mm, got {d_s_mm!r}")
    with source.open(newline="") as f:
        rows = list(csv.reader(f))
    header = rows[0]
    servo = [i for i, name in enumerate(header) if name.startswith("servo_")]
    if not servo:
        raise ValueError(f"{source}: no servo_<id>_mm columns in its header")
    target.parent.mkdir(parents=True, exist_ok=True)
    with target.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow(header)
        for row in rows[1:]:
            for i in servo:
                y = float(row[i])
                if y > 0.0:
                    row[i] = repr(d_s_mm * math.tanh(y / d_s_mm))
            out.writerow(row)
    return len(rows) - 1


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m experiments.ftdcr_v4_softened_commands",
        description=__doc__.splitlines()[0],
    )
    parser.add_argument("d_s_mm", type=float, help="the softening length d_s (mm)")
    parser.add_argument("out_dir", type=Path)
    args = parser.parse_args(argv)
    for name in ("train.csv", "val.csv"):
        n = soften_file(DATA / name, args.out_dir / name, args.d_s_mm)
        print(f"wrote {args.out_dir / name} ({n} rows)")


if __name__ == "__main__":
    main()
