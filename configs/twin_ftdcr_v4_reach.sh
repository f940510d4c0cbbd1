#!/usr/bin/env bash
# Train PPO on the calibrated FTDCR v4 twin (displacement_delta actions) and evaluate it beside
# the IK oracles on held-out goals, on the twin it was trained on (CCKA) and on the MuJoCo twin.
# Outputs: docs/figures/twin_ftdcr_v4/eval_{ccka,mujoco}.{json,png} (docs/sim2real.md).
#   bash configs/twin_ftdcr_v4_reach.sh                       # the CCKA-fitted robot
#   PARAMS=docs/figures/calibration/ftdcr_v4_mujoco_stage0/params.yaml bash configs/twin_ftdcr_v4_reach.sh
# Another fit: PARAMS replaces env.kwargs.params of the config (the copy under RUNS); a fit whose
# params.yaml has a backend: section is evaluated on MuJoCo with those arguments too.
# Training on the MuJoCo twin itself: configs/twin_ftdcr_v4_mujoco_reach.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
PARAMS=${PARAMS:-docs/figures/calibration/ftdcr_v4_ccka/params.yaml}
RUNS=${RUNS:-runs/twin_ftdcr_v4}
OUT=${OUT:-docs/figures/twin_ftdcr_v4}
SEEDS=${SEEDS:-"0 1"}
CCKA_EPISODES=${CCKA_EPISODES:-100}     # per starting state (straight, random)
MUJOCO_EPISODES=${MUJOCO_EPISODES:-10}  # per starting state (a MuJoCo reset of this robot: ~0.03 s)
mkdir -p "$RUNS"
CONFIG="$RUNS/config.yaml"
sed "s#^\(    params: \)[^ ]*#\1$PARAMS#" configs/twin_ftdcr_v4_reach.yaml > "$CONFIG"
for s in $SEEDS; do
  cdcr-gym train "$CONFIG" --seed "$s" --run-dir "$RUNS/seed$s"
done
RUN_DIRS=$(for s in $SEEDS; do echo "$RUNS/seed$s"; done)
python configs/twin_ftdcr_v4_eval.py $RUN_DIRS --oracles --config "$CONFIG" --params "$PARAMS" \
  --env-id cdcr_gym/CCKAReach-v0 --episodes "$CCKA_EPISODES" --tag ccka --out "$OUT"
python configs/twin_ftdcr_v4_eval.py $RUN_DIRS --oracles --config "$CONFIG" --params "$PARAMS" \
  --env-id cdcr_gym/MuJoCoReach-v0 --episodes "$MUJOCO_EPISODES" --tag mujoco --out "$OUT"
