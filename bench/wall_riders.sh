#!/usr/bin/env bash
# Wall riders (docs/multi-rate.md) against multi-rate stepping without them, paired in one
# session: a scene run by this build with /time/wall_riders false and true at each seed, the two
# at once, one per core. Then bench/wall_riders_table.py's table: time stepping (sum of phases)
# and the DEM's share of it (without the gas), the riders' levels and own steps, breakage events
# by generation, and the outlet PSD's KS distance between the two. A benchmark, not CI.
#   bash bench/wall_riders.sh SCENE END_S [OUT_DIR] [SEEDS...]
# e.g. the steady mill's first 6.5 ms (about 10 min) and the shipped mill's 2 ms window:
#   bash bench/wall_riders.sh cases/spiral_jet_mill_steady.json 0.0065 /tmp/riders-steady 7
#   bash bench/wall_riders.sh cases/spiral_jet_mill.json 0.002 /tmp/riders-shipped 7 8 9
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:?usage: bash bench/wall_riders.sh SCENE END_S [OUT_DIR] [SEEDS...]}
end_s=${2:?usage: bash bench/wall_riders.sh SCENE END_S [OUT_DIR] [SEEDS...]}
out=${3:-/tmp/millsim-wall-riders}
shift $(($# < 3 ? $# : 3))
seeds=("${@:-7}")
mkdir -p "$out"
millsim=./build/cli/millsim

variant() {  # variant SEED RIDERS: writes $out/riders_RIDERS-sSEED.json
  python3 - "$scene" "$end_s" "$1" "$2" "$out" <<'PY'
import json, sys
scene_path, end_s, seed, riders, out = sys.argv[1:]
scene = json.load(open(scene_path))
scene["seed"] = int(seed)
scene["time"]["end_s"] = float(end_s)
scene["time"]["multi_rate"] = True
scene["time"]["wall_riders"] = riders == "on"
scene["output"] = {"h5": False, "timeseries_interval_s": 1e-4}
json.dump(scene, open(f"{out}/riders_{riders}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run RIDERS SEED
  "$millsim" run "$out/riders_$1-s$2.json" --out "$out/riders_$1-s$2" --threads 1 \
    --spin-up-cache "$out/spin-up" >"$out/riders_$1-s$2.log" 2>&1
}

for seed in "${seeds[@]}"; do
  variant "$seed" off
  variant "$seed" on
  run off "$seed" &
  run on "$seed"
  wait
done
python3 bench/wall_riders_table.py "$out"
