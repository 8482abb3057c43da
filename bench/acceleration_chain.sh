#!/usr/bin/env bash
# The paper's acceleration chain on the spiral jet mill (cases/jet_mill_acceleration_chain.study.json):
# six stages, one after another on one core (--workers 1, so wall times compare), then the stage
# table with speed-ups (bench/study_stages.py). Hours for the conventional stage; a benchmark.
#   bash bench/acceleration_chain.sh [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/millsim-chain}
mkdir -p "$out"
./build/cli/millsim study cases/jet_mill_acceleration_chain.study.json --local --workers 1 \
  --db "$out/chain.db" --out "$out/studies"
study=$(ls -d "$out"/studies/s* | tail -n 1)
python3 bench/study_stages.py "$study" --markdown \
  --labels "(f) + dust threshold 10 um,(e) + drag cache 5 %,(d) + reduced stiffness,(c) + sub-grid and levels,(b) hashed grid,(a) conventional NBS" --reverse
