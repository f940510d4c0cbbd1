#!/usr/bin/env bash
# The CCKA calibration of the FTDCR v4 robot on its real measurements, and the ablation.
# 1. docs/figures/calibration/ftdcr_v4_ccka/ (report.json, report.md, residuals.png, params.yaml;
#    the robot of the calibrated twin, configs/twin_ftdcr_v4_reach.yaml) and ablation/<name>/
#    beside it, then ablation.md;
# 2. docs/figures/calibration/ftdcr_v4_ccka_selected/: the parameter set chosen on train.csv alone
#    by ftdcr_v4_ccka_selection.py (selection.md there), with the compliant base and the drive
#    backlash, and its ablation (rigid_base: without the base compliance; no_backlash: without
#    the drive backlash).
# 3. docs/figures/calibration/ftdcr_v4_ccka_base/: the first set with the compliant base.
# 4. docs/figures/calibration/ftdcr_v4_ccka_helix/: the set the selection chooses once it may wind
#    the tendons helically (2. plus cable_pitch; selection.md there), and its ablation
#    (parallel_routing: 2. itself).
# About 6 min on 2 shared cores.
set -euo pipefail
OUT=${1:-docs/figures/calibration/ftdcr_v4_ccka}
SELECTED=${2:-docs/figures/calibration/ftdcr_v4_ccka_selected}
HELIX=${3:-docs/figures/calibration/ftdcr_v4_ccka_helix}
DATA=data/real/ftdcr_v4
FIT=base_frame,marker,k_tendons,T0_tendons,cable_angles
run() { python -m training.studies.calibrate "$DATA/train.csv" --robot ftdcr_v4 --backend ccka \
  --validate "$DATA/val.csv" --quiet "$@"; }
run --fit "$FIT" --out "$OUT"
run --fit base_frame,marker,T0_tendons,cable_angles --stiffness-scale 1000 --out "$OUT/ablation/rigid_tendons"
run --fit "$FIT" --linear-law --out "$OUT/ablation/no_slack"
run --fit marker,k_tendons,T0_tendons,cable_angles --out "$OUT/ablation/no_base_frame"
python -m training.studies.calibrate --ablation-table "$OUT"
# the same set with the compliant base: the MuJoCo fit's warm start (ftdcr_v4_mujoco.sh)
run --fit "$FIT,base_compliance" --out "${OUT}_base"

# the set chosen by ftdcr_v4_ccka_selection.py on train.csv alone: E, pretensions, tendon angles
# and the compliant base (k stays nominal)
SEL=base_frame,marker,E,T0_tendons,cable_angles,base_compliance,drive_backlash
run --fit "$SEL" --out "$SELECTED"
run --fit base_frame,marker,E,T0_tendons,cable_angles,drive_backlash --stiffness-scale 1000 \
  --out "$SELECTED/ablation/rigid_tendons"
run --fit "$SEL" --linear-law --out "$SELECTED/ablation/no_slack"
run --fit marker,E,T0_tendons,cable_angles,base_compliance,drive_backlash \
  --out "$SELECTED/ablation/no_base_frame"
run --fit base_frame,marker,E,T0_tendons,cable_angles,drive_backlash --out "$SELECTED/ablation/rigid_base"
run --fit base_frame,marker,E,T0_tendons,cable_angles,base_compliance --out "$SELECTED/ablation/no_backlash"
python -m training.studies.calibrate --ablation-table "$SELECTED"

# the set chosen once the selection may wind the tendons helically: the same plus cable_pitch
HEL="$SEL,cable_pitch"
run --fit "$HEL" --out "$HELIX"
run --fit base_frame,marker,E,T0_tendons,cable_angles,drive_backlash,cable_pitch \
  --stiffness-scale 1000 --out "$HELIX/ablation/rigid_tendons"
run --fit "$HEL" --linear-law --out "$HELIX/ablation/no_slack"
run --fit marker,E,T0_tendons,cable_angles,base_compliance,drive_backlash,cable_pitch \
  --out "$HELIX/ablation/no_base_frame"
run --fit base_frame,marker,E,T0_tendons,cable_angles,drive_backlash,cable_pitch \
  --out "$HELIX/ablation/rigid_base"
run --fit base_frame,marker,E,T0_tendons,cable_angles,base_compliance,cable_pitch \
  --out "$HELIX/ablation/no_backlash"
run --fit "$SEL" --out "$HELIX/ablation/parallel_routing"
python -m training.studies.calibrate --ablation-table "$HELIX"
