#!/usr/bin/env bash
# The MuJoCo calibration of the FTDCR v4 robot on its real displacement measurements: the rows
# replayed in order with their recorded timing (gaps capped at 1 s), the geometry and
# tendon drive of the CCKA set selected on train.csv (configs/calibration/ftdcr_v4_ccka.sh,
# ftdcr_v4_ccka_selected/: E, pretensions, tendon angles, the compliant base, the drives'
# backlash). The drives pull
# with the fitted tendon drive's law, uncapped (as the CCKA fit). The frame columns of the
# Jacobian share the unperturbed robot; E, the payload, the base compliance, the backbone
# friction and (under gravity) the base tilt are simulated robots of one batched MuJoCo model.
#
#   Main fit, the structure chosen on train.csv alone (configs/calibration/ftdcr_v4_mujoco_selection.py,
#   ftdcr_v4_mujoco_selection_helix/): no gravity; base frame, marker, E, base compliance, drive
#   backlash, backbone friction, 4 optimiser steps, from the CCKA set with helically wound
#   tendons (ftdcr_v4_ccka_helix/) -> ftdcr_v4_mujoco_helix/
#   The same from the CCKA set with parallel tendons (ftdcr_v4_ccka_selected/; the structure chosen
#   from there: ftdcr_v4_mujoco_selection/) -> ftdcr_v4_mujoco_selected/
#   With gravity (not selected; kept for comparison):
#   A. base frame, marker, E, tip payload, base compliance, drive backlash, 4 optimiser steps
#      -> docs/figures/calibration/ftdcr_v4_mujoco_base_selected/
#   B. + backbone friction (payload fixed at A's), 4 steps -> ftdcr_v4_mujoco_backbone_selected/
#   With a drive softening (not selected: worse on the two-section rows; kept for comparison):
#   C. the parallel-tendon fit's names + drive_softening (from 10 1/m), 4 steps
#      -> ftdcr_v4_mujoco_softening/
#   D. the main fit's names + drive_softening, from the helical CCKA fit, 4 steps
#      -> ftdcr_v4_mujoco_helix_softening/
#
# Wall times on 2 shared cores: in each report.md ("model evaluations in ... s"); the ablation:
# configs/calibration/ftdcr_v4_mujoco_ablation.py.
#
# The twins' robot (configs/twin_ftdcr_v4_mujoco_reach.sh), ftdcr_v4_mujoco_stage0/, is an earlier
# rigid-base fit (frame, marker, E, payload from ftdcr_v4_ccka/) made when the replay capped the
# drives at the robot's max_tension; its command is in its params.yaml.
set -euo pipefail
F=docs/figures/calibration
DATA=data/real/ftdcr_v4
run() { python -m training.studies.calibrate "$DATA/train.csv" --backend mujoco \
  --validate "$DATA/val.csv" --backend-arg physics_timestep=0.04 \
  --backend-arg control_timestep=0.04 --max-gap 1.0 "$@"; }
payload() { python -c "import sys, yaml; print(yaml.safe_load(open(sys.argv[1]))['calibration']['fitted']['tip_payload'])" "$1"; }

H=$F/ftdcr_v4_ccka_helix/params.yaml
run --robot "$H" --backend-arg gravity=false \
  --fit base_frame,marker,E,base_compliance,drive_backlash,backbone_friction --start-from "$H" \
  --start backbone_friction=0.001 --max-evals 4 --out "$F/ftdcr_v4_mujoco_helix"
S=$F/ftdcr_v4_ccka_selected/params.yaml
run --robot "$S" --backend-arg gravity=false \
  --fit base_frame,marker,E,base_compliance,drive_backlash,backbone_friction --start-from "$S" \
  --start backbone_friction=0.001 --max-evals 4 --out "$F/ftdcr_v4_mujoco_selected"
run --robot "$S" --fit base_frame,marker,E,payload,base_compliance,drive_backlash --start-from "$S" \
  --max-evals 4 --out "$F/ftdcr_v4_mujoco_base_selected"
A="$F/ftdcr_v4_mujoco_base_selected/params.yaml"
run --robot "$A" --fit base_frame,marker,E,base_compliance,drive_backlash,backbone_friction \
  --start-from "$A" \
  --start backbone_friction=0.001 --backend-arg tip_payload="$(payload "$A")" --max-evals 4 \
  --out "$F/ftdcr_v4_mujoco_backbone_selected"
run --robot "$S" --backend-arg gravity=false \
  --fit base_frame,marker,E,base_compliance,drive_backlash,backbone_friction,drive_softening \
  --start-from "$S" --start backbone_friction=0.001 --start drive_softening=10 --max-evals 4 \
  --out "$F/ftdcr_v4_mujoco_softening"
run --robot "$H" --backend-arg gravity=false \
  --fit base_frame,marker,E,base_compliance,drive_backlash,backbone_friction,drive_softening \
  --start-from "$H" --start backbone_friction=0.001 --start drive_softening=10 --max-evals 4 \
  --out "$F/ftdcr_v4_mujoco_helix_softening"
