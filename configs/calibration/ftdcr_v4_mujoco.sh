#!/usr/bin/env bash
# The MuJoCo calibration of the FTDCR v4 robot on its real displacement measurements: the rows
# replayed in order with their recorded timing (gaps capped at 1 s), gravity on, the geometry and
# tendon drive of a CCKA fit (configs/calibration/ftdcr_v4_ccka.sh). The frame columns of the
# Jacobian share the unperturbed robot; E, the payload, the base compliance, the backbone
# friction and (under gravity) the base tilt are simulated robots of one batched MuJoCo model.
#
# The model (from the CCKA set selected on train.csv, ftdcr_v4_ccka_selected/: E, pretensions,
# tendon angles, the compliant base):
#   A. base frame, marker, E, tip payload, base compliance, 4 optimiser steps
#      -> docs/figures/calibration/ftdcr_v4_mujoco_base_selected/
#   B. + backbone friction (payload fixed at A's), 4 steps -> ftdcr_v4_mujoco_backbone_selected/
# Comparisons:
#   A and B from the CCKA fit with per-tendon k and T0 and the compliant base
#   (ftdcr_v4_ccka_base/) -> ftdcr_v4_mujoco_base/, ftdcr_v4_mujoco_backbone/
#   rigid base (from ftdcr_v4_ccka/): stage 0 (A without the base compliance) -> ftdcr_v4_mujoco_stage0/,
#   continued 5 steps -> ftdcr_v4_mujoco_frictionless/, + cable (capstan) friction mu, 2 steps
#   -> ftdcr_v4_mujoco/, every tendon's pretension refitted, 3 steps -> ftdcr_v4_mujoco_T0/
# Wall times on 2 shared cores: in each report.md ("model evaluations in ... s"); the ablation:
# configs/calibration/ftdcr_v4_mujoco_ablation.py.
set -euo pipefail
F=docs/figures/calibration
DATA=data/real/ftdcr_v4
run() { python -m training.studies.calibrate "$DATA/train.csv" --backend mujoco \
  --validate "$DATA/val.csv" --backend-arg physics_timestep=0.04 \
  --backend-arg control_timestep=0.04 --max-gap 1.0 "$@"; }
payload() { python -c "import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))['calibration']['fitted']['tip_payload'])" "$1"; }

# A and B: run_ab START_PARAMS OUT_SUFFIX
run_ab() {
  run --robot "$1" --fit base_frame,marker,E,payload,base_compliance --start-from "$1" \
    --max-evals 4 --out "$F/ftdcr_v4_mujoco_base$2"
  local a="$F/ftdcr_v4_mujoco_base$2/params.yaml"
  run --robot "$a" --fit base_frame,marker,E,base_compliance,backbone_friction --start-from "$a" \
    --start backbone_friction=0.001 --backend-arg tip_payload="$(payload "$a")" --max-evals 4 \
    --out "$F/ftdcr_v4_mujoco_backbone$2"
}
run_ab $F/ftdcr_v4_ccka_selected/params.yaml _selected
run_ab $F/ftdcr_v4_ccka_base/params.yaml ""

CCKA=$F/ftdcr_v4_ccka/params.yaml
FIT=base_frame,marker,E,payload
run --robot "$CCKA" --fit "$FIT" --start-from "$CCKA" --max-evals 4 --out $F/ftdcr_v4_mujoco_stage0
run --robot "$CCKA" --fit "$FIT" --start-from $F/ftdcr_v4_mujoco_stage0/params.yaml --max-evals 5 \
  --out $F/ftdcr_v4_mujoco_frictionless
STAGE1=$F/ftdcr_v4_mujoco_frictionless/params.yaml
run --robot "$STAGE1" --fit base_frame,marker,mu --start-from "$STAGE1" \
  --start friction_coefficient=0.05 --backend-arg tip_payload="$(payload "$STAGE1")" --max-evals 2 \
  --out $F/ftdcr_v4_mujoco
run --robot "$CCKA" --fit "$FIT,T0_tendons" --start-from "$CCKA" --max-evals 3 --out $F/ftdcr_v4_mujoco_T0
