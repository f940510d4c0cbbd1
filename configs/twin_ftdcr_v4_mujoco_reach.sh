#!/usr/bin/env bash
# Train PPO on the calibrated MuJoCo twin of the FTDCR v4 robot (displacement_delta actions) and
# evaluate it beside the IK oracles and the policies trained on the CCKA twin, on the same
# held-out goals of the MuJoCo twin.
# Outputs: docs/figures/twin_ftdcr_v4/eval_mujoco_trained.{json,md,png} (docs/sim2real.md
# "Train on the MuJoCo twin") and docs/figures/twin_ftdcr_v4/reset_time_mujoco.json.
#   bash configs/twin_ftdcr_v4_mujoco_reach.sh
# The two seeds train side by side (about 80 minutes each on a shared two-core machine).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=configs/twin_ftdcr_v4_mujoco_reach.yaml
PARAMS=docs/figures/calibration/ftdcr_v4_mujoco_stage0/params.yaml
RUNS=${RUNS:-runs/twin_ftdcr_v4_mujoco}
OUT=${OUT:-docs/figures/twin_ftdcr_v4}
EPISODES=${EPISODES:-200}  # per starting state (straight, random): 400 goals, ~20 min with the oracles
mkdir -p "$RUNS"
python -m experiments.twin_mujoco_reset --config "$CONFIG" --out "$OUT/reset_time_mujoco.json"
cdcr-gym train "$CONFIG" --seed 0 --run-dir "$RUNS/seed0" > "$RUNS/train_seed0.log" 2>&1 &
cdcr-gym train "$CONFIG" --seed 1 --run-dir "$RUNS/seed1" > "$RUNS/train_seed1.log" 2>&1 &
wait
# the policies trained on the CCKA twin (docs/figures/twin_ftdcr_v4/seed*), under their own names
mkdir -p "$RUNS/ccka"
ln -sfn "$PWD/$OUT/seed0" "$RUNS/ccka/ccka_seed0"
ln -sfn "$PWD/$OUT/seed1" "$RUNS/ccka/ccka_seed1"
python configs/twin_ftdcr_v4_eval.py "$RUNS/ccka/ccka_seed0" "$RUNS/ccka/ccka_seed1" --oracles \
  --config "$CONFIG" --params "$PARAMS" --env-id cdcr_gym/MuJoCoReach-v0 \
  --episodes "$EPISODES" --tag mujoco_trained --out "$OUT"
# added to the same file (same episodes), named mujoco_seed0/1
mkdir -p "$RUNS/mujoco"
ln -sfn "$PWD/$RUNS/seed0" "$RUNS/mujoco/mujoco_seed0"
ln -sfn "$PWD/$RUNS/seed1" "$RUNS/mujoco/mujoco_seed1"
python configs/twin_ftdcr_v4_eval.py "$RUNS/mujoco/mujoco_seed0" "$RUNS/mujoco/mujoco_seed1" \
  --config "$CONFIG" --params "$PARAMS" --env-id cdcr_gym/MuJoCoReach-v0 \
  --episodes "$EPISODES" --tag mujoco_trained --out "$OUT"
