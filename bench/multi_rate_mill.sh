#!/usr/bin/env bash
# The shipped spiral jet mill against the commit before issue 29, paired in one session: the same
# 2 ms window (cases/spiral_jet_mill.json) run by a build of the commit before the work (single
# rate at the default 20 steps per contact, no reduced stiffness, as it shipped: BASE) and by this
# build as the case ships (multi-rate stepping, 8 steps per contact, reduced stiffness below
# 16.39 um), as shipped without reduced stiffness, and single-rate at 20 steps per contact
# without reduced stiffness (this build's own reference, "single_here": the physics changed on
# purpose since BASE, so accuracy is judged against it), each at the seeds given (7, 8 and 9 by
# default), two runs at a time on two cores (one per core). Then the table of
# bench/multi_rate_table.py: time stepping, product PSD, breakage events by generation, and the
# KS distance of each product to BASE's run of the same seed against BASE's seed-to-seed
# scatter; then the same against single_here. Each
# table gives the speed-up for the window and per simulated particle-millisecond, with medians.
# About 20 minutes for the three default seeds on this machine; a benchmark, not CI. With
# MULTI_RATE_20=1 the second core runs this build multi-rate at 20 steps per contact without
# reduced stiffness ("multi_rate_20": multi-rate stepping's own accuracy, the step of single_here)
# instead of single_here.
#   [MULTI_RATE_20=1] bash bench/multi_rate_mill.sh BASE_MILLSIM [OUT_DIR [SEED...]]
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: bash bench/multi_rate_mill.sh BASE_MILLSIM [OUT_DIR [SEED...]]}
out=${2:-/tmp/millsim-multi-rate}
shift $(($# < 2 ? $# : 2))
seeds=("$@")
((${#seeds[@]} > 0)) || seeds=(7 8 9)
mkdir -p "$out"
cp ./build/cli/millsim "$out/millsim"  # this build, copied: the tree may be rebuilt meanwhile
new=$out/millsim

variant() {  # variant NAME SEED: writes $out/NAME-sSEED.json
  python3 - "$1" "$2" "$out" <<'PY'
import json, sys
name, seed, out = sys.argv[1:]
scene = json.load(open("cases/spiral_jet_mill.json"))
scene["seed"] = int(seed)
if name in ("single", "single_here", "multi_rate_20"):
    scene["time"].pop("steps_per_contact", None)  # the default 20
if name in ("single", "single_here"):  # the case as the commit before the work shipped it
    scene["time"].pop("multi_rate", None)
if name in ("single", "single_here", "shipped_without_reduced", "multi_rate_20"):
    scene["contact"].pop("reduced_stiffness", None)
scene["output"] = {"h5": False, "timeseries_interval_s": 2e-5}
json.dump(scene, open(f"{out}/{name}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run BINARY NAME SEED
  "$1" run "$out/$2-s$3.json" --out "$out/$2-s$3" >"$out/$2-s$3.log" 2>&1
}

reference=single_here
[[ ${MULTI_RATE_20:-0} == 1 ]] && reference=multi_rate_20
for seed in "${seeds[@]}"; do
  for name in single $reference shipped shipped_without_reduced; do variant "$name" "$seed"; done
done
# One core runs the commit before and then this build as shipped; the other this build single-rate
# (or multi-rate at 20 steps) and then without reduced stiffness (about the same time on each).
for seed in "${seeds[@]}"; do
  (run "$base" single "$seed" && run "$new" shipped "$seed") &
  run "$new" "$reference" "$seed"
  run "$new" shipped_without_reduced "$seed"
  wait
done
python3 bench/multi_rate_table.py "$out"
python3 bench/multi_rate_table.py "$out" "$reference"
