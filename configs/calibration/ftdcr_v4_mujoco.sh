#!/usr/bin/env bash
# The MuJoCo calibration of the FTDCR v4 robot on its real displacement measurements: the rows
# replayed in order with their recorded timing (gaps capped at 1 s), gravity on, the geometry and
# tendon drive of the CCKA fit docs/figures/calibration/ftdcr_v4_ccka/ (configs/calibration/
# ftdcr_v4_ccka.sh). The frame columns of the Jacobian share the unperturbed robot; E, the
# payload and (under gravity) the base tilt are simulated robots of one batched MuJoCo model.
#
# Stage 0: base frame, marker, E, tip payload from the CCKA values, 4 optimiser steps
#   -> docs/figures/calibration/ftdcr_v4_mujoco_stage0/
# Stage 1 (frictionless): the same, continued from stage 0 for 5 more steps
#   -> docs/figures/calibration/ftdcr_v4_mujoco_frictionless/
# Stage 2: the cable friction coefficient mu added to the frame and marker, from stage 1 (a
#   friction replay costs ~5x a frictionless one), 2 steps -> docs/figures/calibration/ftdcr_v4_mujoco/
# Comparison: stage 1's fit list (+ T0 per section) warm-started from the CCKA set selected on
#   train.csv (ftdcr_v4_ccka_selected/) -> docs/figures/calibration/ftdcr_v4_mujoco_selected_start/
# Wall times on 2 shared cores: in each report.md ("model evaluations in ... s").
set -euo pipefail
OUT=${1:-docs/figures/calibration/ftdcr_v4_mujoco}
DATA=data/real/ftdcr_v4
CCKA=docs/figures/calibration/ftdcr_v4_ccka/params.yaml
FIT=base_frame,marker,E,payload
run() { python -m training.studies.calibrate "$DATA/train.csv" --backend mujoco \
  --validate "$DATA/val.csv" --backend-arg physics_timestep=0.04 \
  --backend-arg control_timestep=0.04 --max-gap 1.0 "$@"; }
run --robot "$CCKA" --fit "$FIT" --start-from "$CCKA" --max-evals 4 --out "${OUT}_stage0"
run --robot "$CCKA" --fit "$FIT" --start-from "${OUT}_stage0/params.yaml" --max-evals 5 \
  --out "${OUT}_frictionless"
STAGE1="${OUT}_frictionless/params.yaml"
PAYLOAD=$(python -c "import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))['calibration']['fitted']['tip_payload'])" "$STAGE1")
run --robot "$STAGE1" --fit base_frame,marker,mu --start-from "$STAGE1" \
  --start friction_coefficient=0.05 --backend-arg tip_payload="$PAYLOAD" --max-evals 2 \
  --out "$OUT"
SELECTED=docs/figures/calibration/ftdcr_v4_ccka_selected/params.yaml
run --robot "$SELECTED" --fit "$FIT,T0_sections" --start-from "$SELECTED" --max-evals 5 --quiet \
  --out "${OUT}_selected_start"
# Comparison: every tendon's pretension refitted under gravity (18 parameters), from the CCKA
# values, 3 steps -> docs/figures/calibration/ftdcr_v4_mujoco_T0/
run --robot "$CCKA" --fit "$FIT,T0_tendons" --start-from "$CCKA" --max-evals 3 --out "${OUT}_T0"
