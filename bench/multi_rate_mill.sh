#!/usr/bin/env bash
# Multi-rate stepping on the shipped spiral jet mill (issue 29), paired in one session: the same
# 2 ms window (cases/spiral_jet_mill.json) run by a build of the commit before the work (single
# rate at the default 20 steps per contact, as it shipped: BASE) and by this build with its
# shipped settings (multi-rate stepping, the case's steps per contact), and with
# multi-rate stepping and reduced stiffness, each at seeds 7, 8 and 9, two runs at a time on two
# cores (one per core). Then the table of
# bench/multi_rate_table.py: time stepping, product PSD, breakage events by generation, and the
# KS distance of each product to the single-rate run of the same seed against the single-rate
# runs' own seed-to-seed scatter. About 25 minutes on this machine; a benchmark, not CI.
#   bash bench/multi_rate_mill.sh BASE_MILLSIM [OUT_DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: bash bench/multi_rate_mill.sh BASE_MILLSIM [OUT_DIR]}
out=${2:-/tmp/millsim-multi-rate}
mkdir -p "$out"
new=./build/cli/millsim

variant() {  # variant NAME SEED MULTI_RATE REDUCED: writes $out/NAME-sSEED.json
  python3 - "$1" "$2" "$3" "$4" "$out" <<'PY'
import json, sys
name, seed, multi, reduced, out = sys.argv[1:]
scene = json.load(open("cases/spiral_jet_mill.json"))
scene["seed"] = int(seed)
scene["time"].pop("multi_rate", None)
scene["contact"].pop("reduced_stiffness", None)
if multi == "0":  # the case as the commit before the work shipped it: 20 steps per contact
    scene["time"].pop("steps_per_contact", None)
if multi == "1":
    scene["time"]["multi_rate"] = True
if reduced == "1":
    scene["contact"]["reduced_stiffness"] = True
scene["output"] = {"h5": False, "timeseries_interval_s": 2e-5}
json.dump(scene, open(f"{out}/{name}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run BINARY NAME SEED
  "$1" run "$out/$2-s$3.json" --out "$out/$2-s$3" >"$out/$2-s$3.log" 2>&1
}

for seed in 7 8 9; do
  variant single "$seed" 0 0
  variant multi "$seed" 1 0
  variant multi_reduced "$seed" 1 1
done
# One core runs the single-rate build of the commit before; the other this build, with reduced
# stiffness and then with the shipped settings (multi-rate alone).
for seed in 7 8 9; do
  run "$base" single "$seed" &
  run "$new" multi_reduced "$seed"
  run "$new" multi "$seed"
  wait
done
python3 bench/multi_rate_table.py "$out"
