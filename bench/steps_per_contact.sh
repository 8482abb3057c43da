#!/usr/bin/env bash
# The automatic step's resolution of the shortest contact (/time/steps_per_contact, issue 29 item
# 3), paired in one session: bench/scene_settings.sh with the setting time.steps_per_contact at
# each value (runs named spcN), then bench/steps_per_contact_table.py's table: time stepping (sum
# of phases), the step, product PSD, breakage events by generation, and each product's KS
# distance to the run of the same seed at the first value, against that value's own seed-to-seed
# scatter. A benchmark, not CI.
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
variants=()
for n in "${values[@]}"; do variants+=("spc$n=$n"); done
bash bench/scene_settings.sh "$scene" "$end_s" "$out" time.steps_per_contact "${variants[@]}" \
  -- "${@:-7}" >/dev/null
python3 bench/steps_per_contact_table.py "$out" "${values[0]}"
