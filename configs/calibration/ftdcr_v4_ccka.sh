#!/usr/bin/env bash
# The CCKA calibration of the FTDCR v4 robot on its real measurements, and the ablation.
# Writes docs/figures/calibration/ftdcr_v4_ccka/ (report.json, report.md, residuals.png,
# params.yaml) and ablation/<name>/ beside it, then ablation.md. About 6 min on 2 cores.
set -euo pipefail
OUT=${1:-docs/figures/calibration/ftdcr_v4_ccka}
DATA=data/real/ftdcr_v4
FIT=base_frame,marker,k_tendons,T0_tendons,cable_angles
run() { python -m training.studies.calibrate "$DATA/train.csv" --robot ftdcr_v4 --backend ccka \
  --validate "$DATA/val.csv" --quiet "$@"; }
run --fit "$FIT" --out "$OUT"
run --fit base_frame,marker,T0_tendons,cable_angles --stiffness-scale 1000 --out "$OUT/ablation/rigid_tendons"
run --fit "$FIT" --linear-law --out "$OUT/ablation/no_slack"
run --fit marker,k_tendons,T0_tendons,cable_angles --out "$OUT/ablation/no_base_frame"
python -m training.studies.calibrate --ablation-table "$OUT"
