#!/usr/bin/env bash
# One scene setting at several values, paired in one session (issue 29 item 3: settings by error
# budget): the scene run by this build at every value and seed, two runs at a time on two cores
# (the values of one seed together, so each pair shares the machine's state). Then
# bench/scene_settings_table.py's table: time stepping (the sum of phases), speed-up against the
# first value at the same seed, product PSD, breakage events by generation, limiter events and
# the KS distance of each product to the first value's run of the same seed, against that
# value's own seed-to-seed scatter. A benchmark, not CI. This build's binary is copied first, so
# the build may change meanwhile.
#   bash bench/scene_settings.sh SCENE END_S OUT_DIR SETTING NAME=JSON [NAME=JSON ...] -- SEED...
# SETTING is a dotted path into the scene (as a study's "set"); JSON its value in that variant.
# e.g. reduced stiffness off and on in the shipped mill's 2 ms window:
#   bash bench/scene_settings.sh cases/spiral_jet_mill.json 0.002 /tmp/rs \
#     contact.reduced_stiffness off=false on='{"threshold_diameter_m":1.639e-5}' -- 7 8 9
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: bash bench/scene_settings.sh SCENE END_S OUT_DIR SETTING NAME=JSON... -- SEED..."
scene=${1:?$usage}
end_s=${2:?$usage}
out=${3:?$usage}
setting=${4:?$usage}
shift 4
variants=()
while (($# > 0)) && [[ $1 != -- ]]; do
  variants+=("$1")
  shift
done
(($# > 0)) && shift
seeds=("${@:-7}")
((${#variants[@]} >= 2)) || { echo "$usage" >&2; exit 2; }
mkdir -p "$out"
cp "${MILLSIM:-./build/cli/millsim}" "$out/millsim"

variant() {  # variant NAME=JSON SEED: writes $out/NAME-sSEED.json
  python3 - "$scene" "$end_s" "$setting" "$1" "$2" "$out" <<'PY'
import json, sys
scene_path, end_s, setting, name_value, seed, out = sys.argv[1:]
name, value = name_value.split("=", 1)
scene = json.load(open(scene_path))
scene["seed"] = int(seed)
scene["time"]["end_s"] = float(end_s)
node = scene
*parents, leaf = setting.split(".")
for key in parents:
    node = node.setdefault(key, {})
node[leaf] = json.loads(value)
scene["output"] = {"h5": False, "timeseries_interval_s": 1e-4}
json.dump(scene, open(f"{out}/{name}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run NAME SEED
  "$out/millsim" run "$out/$1-s$2.json" --out "$out/$1-s$2" --threads 1 \
    --spin-up-cache "$out/spin-up" >"$out/$1-s$2.log" 2>&1
}

jobs_running=0
for seed in "${seeds[@]}"; do
  for v in "${variants[@]}"; do
    variant "$v" "$seed"
    run "${v%%=*}" "$seed" &
    jobs_running=$((jobs_running + 1))
    if ((jobs_running == 2)); then
      wait -n
      jobs_running=$((jobs_running - 1))
    fi
  done
done
wait
python3 bench/scene_settings_table.py "$out" "${variants[@]%%=*}"
