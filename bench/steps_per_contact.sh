#!/usr/bin/env bash
# The automatic step's resolution of the shortest contact (/time/steps_per_contact, issue 29 item
# 3), paired in one session: a scene run by this build at each value of steps_per_contact and
# each seed, two runs at a time on two cores (one per core, the values of one seed together).
# Then bench/steps_per_contact_table.py's table: time stepping (sum of phases), the step, product
# PSD, breakage events by generation, and each product's KS distance to the run of the same seed
# at the first value, against that value's own seed-to-seed scatter. A benchmark, not CI.
#   bash bench/steps_per_contact.sh SCENE END_S OUT_DIR "N1 N2 ..." SEED...
# e.g. the shipped mill's 2 ms window at 20 (the default), 12 and 8 steps per contact:
#   bash bench/steps_per_contact.sh cases/spiral_jet_mill.json 0.002 /tmp/spc "20 12 8" 7 8 9 10 11
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: bash bench/steps_per_contact.sh SCENE END_S OUT_DIR \"N1 N2 ...\" SEED..."
scene=${1:?$usage}
end_s=${2:?$usage}
out=${3:?$usage}
read -r -a values <<<"${4:?$usage}"
shift 4
seeds=("${@:-7}")
mkdir -p "$out"
millsim=${MILLSIM:-./build/cli/millsim}

variant() {  # variant N SEED: writes $out/spcN-sSEED.json
  python3 - "$scene" "$end_s" "$1" "$2" "$out" <<'PY'
import json, sys
scene_path, end_s, n, seed, out = sys.argv[1:]
scene = json.load(open(scene_path))
scene["seed"] = int(seed)
scene["time"]["end_s"] = float(end_s)
scene["time"]["steps_per_contact"] = float(n)
scene["output"] = {"h5": False, "timeseries_interval_s": 1e-4}
json.dump(scene, open(f"{out}/spc{n}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run N SEED
  "$millsim" run "$out/spc$1-s$2.json" --out "$out/spc$1-s$2" --threads 1 \
    --spin-up-cache "$out/spin-up" >"$out/spc$1-s$2.log" 2>&1
}

jobs_running=0
for seed in "${seeds[@]}"; do
  for n in "${values[@]}"; do
    variant "$n" "$seed"
    run "$n" "$seed" &
    jobs_running=$((jobs_running + 1))
    if ((jobs_running == 2)); then
      wait -n
      jobs_running=$((jobs_running - 1))
    fi
  done
done
wait
python3 bench/steps_per_contact_table.py "$out" "${values[0]}"
