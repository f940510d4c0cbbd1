#!/usr/bin/env bash
# The MuJoCo calibration of the FTDCR v4 robot on its real displacement measurements: the rows
# replayed in order with their recorded timing (gaps capped at 1 s), warm-started from the CCKA
# fit (its geometry, tendon drive and frame: configs/calibration/ftdcr_v4_ccka.sh), gravity on.
# Fits the base frame, the marker offset, E and a tip payload (5 simulated robots per Jacobian:
# the frame columns share the unperturbed robot). Writes docs/figures/calibration/ftdcr_v4_mujoco/
# (about 20 min on 2 shared cores) and ftdcr_v4_mujoco_T0/ (about 15 min).
set -euo pipefail
OUT=${1:-docs/figures/calibration/ftdcr_v4_mujoco}
DATA=data/real/ftdcr_v4
CCKA=docs/figures/calibration/ftdcr_v4_ccka/params.yaml
python -m training.studies.calibrate "$DATA/train.csv" --robot "$CCKA" --backend mujoco \
  --validate "$DATA/val.csv" --fit base_frame,marker,E,payload --start-from "$CCKA" \
  --backend-arg physics_timestep=0.04 --backend-arg control_timestep=0.04 --max-gap 1.0 \
  --max-evals 4 --out "$OUT"
# The same with every tendon's pretension refitted under gravity (18 parameters, 14 simulated
# robots per Jacobian, 3 optimiser steps): docs/figures/calibration/ftdcr_v4_mujoco_T0/.
python -m training.studies.calibrate "$DATA/train.csv" --robot "$CCKA" --backend mujoco \
  --validate "$DATA/val.csv" --fit base_frame,marker,E,payload,T0_tendons --start-from "$CCKA" \
  --backend-arg physics_timestep=0.04 --backend-arg control_timestep=0.04 --max-gap 1.0 \
  --max-evals 3 --out "${OUT}_T0"
