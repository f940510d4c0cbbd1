#!/usr/bin/env bash
# The MuJoCo calibration of the FTDCR v4 robot on its real displacement measurements: the rows
# replayed in order with their recorded timing (gaps capped at 1 s), gravity on, warm-started
# from the selected CCKA fit (its geometry, tendon drive and frame: ftdcr_v4_ccka_selected/, the
# last command of configs/calibration/ftdcr_v4_ccka.sh).
#
# Stage 1 (frictionless): the base frame, the marker offset, E (with the CCKA fit's per-tendon k
#   it scales the tendon/rod stiffness ratio), a tip payload and the pretension per section (the
#   Jacobian's columns as robots of one batched MuJoCo model; the frame columns share the
#   unperturbed robot) -> docs/figures/calibration/ftdcr_v4_mujoco_frictionless/
# Stage 2: the cable friction coefficient mu added, started from stage 1 (friction costs ~5x per
#   replay, so it is fitted with the frame and marker only) -> docs/figures/calibration/ftdcr_v4_mujoco/
# Wall times on 2 shared cores: in each report.md ("model evaluations in ... s").
set -euo pipefail
OUT=${1:-docs/figures/calibration/ftdcr_v4_mujoco}
DATA=data/real/ftdcr_v4
CCKA=docs/figures/calibration/ftdcr_v4_ccka_selected/params.yaml
TIMING=(--backend-arg physics_timestep=0.04 --backend-arg control_timestep=0.04 --max-gap 1.0)
python -m training.studies.calibrate "$DATA/train.csv" --robot "$CCKA" --backend mujoco \
  --validate "$DATA/val.csv" --fit base_frame,marker,E,payload,T0_sections --start-from "$CCKA" \
  "${TIMING[@]}" --max-evals 5 --quiet --out "${OUT}_frictionless"
STAGE1="${OUT}_frictionless/params.yaml"
PAYLOAD=$(python -c "import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))['calibration']['fitted']['tip_payload'])" "$STAGE1")
python -m training.studies.calibrate "$DATA/train.csv" --robot "$STAGE1" --backend mujoco \
  --validate "$DATA/val.csv" --fit base_frame,marker,mu --start-from "$STAGE1" \
  --start friction_coefficient=0.05 --backend-arg tip_payload="$PAYLOAD" \
  "${TIMING[@]}" --max-evals 2 --quiet --out "$OUT"
