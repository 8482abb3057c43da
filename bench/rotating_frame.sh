#!/usr/bin/env bash
# The neighbour list's turning frame and skin by speed (docs/contact-search.md) on a mill, paired
# in one session: at each seed the scene run by this build in the lab frame (`lab`:
# /search/rotating_frame and /search/skin_by_speed false), in the turning frame alone (`turning`)
# and with skin by speed as well (`shares`, the default), each run at the same time as a run of
# the same seed by a build of the commit before (BASE), one per core: every run has a partner
# of the same kind, and each is compared with the BASE run beside it. Then
# bench/rotating_frame_table.py's table: time stepping, the neighbour search's and the contact
# forces' seconds, rebuilds, the product PSD, breakage events by generation, and the KS distance
# of each product to BASE's of the same seed against BASE's seed-to-seed scatter. A benchmark,
# not CI; the shipped mill's 2 ms at three seeds take about 25 minutes here. This build's binary
# is copied first, so the build may change meanwhile.
#   bash bench/rotating_frame.sh BASE_MILLSIM SCENE END_S [OUT_DIR] [SEEDS...]
#   bash bench/rotating_frame.sh /tmp/base/millsim cases/spiral_jet_mill.json 0.002 /tmp/frame 7 8 9
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: bash bench/rotating_frame.sh BASE_MILLSIM SCENE END_S [OUT_DIR] [SEEDS...]"
base=${1:?$usage}
scene=${2:?$usage}
end_s=${3:?$usage}
out=${4:-/tmp/millsim-rotating-frame}
shift $(($# < 4 ? $# : 4))
seeds=("${@:-7}")
mkdir -p "$out"
cp ./build/cli/millsim "$out/millsim"
millsim=$out/millsim

variant() {  # variant NAME SEED FRAME SHARES: writes $out/NAME-sSEED.json (keep: the scene's own)
  python3 - "$scene" "$end_s" "$1" "$2" "$3" "$4" "$out" <<'PY'
import json, sys
scene_path, end_s, name, seed, frame, shares, out = sys.argv[1:]
scene = json.load(open(scene_path))
scene["seed"] = int(seed)
scene["time"]["end_s"] = float(end_s)
if frame != "keep":
    scene.setdefault("search", {})["rotating_frame"] = frame == "true"
if shares != "keep":
    scene.setdefault("search", {})["skin_by_speed"] = shares == "true"
scene["output"] = {"h5": False, "timeseries_interval_s": 2e-5}
json.dump(scene, open(f"{out}/{name}-s{seed}.json", "w"), indent=1)
PY
}

run() {  # run BINARY NAME SEED
  "$1" run "$out/$2-s$3.json" --out "$out/$2-s$3" --threads 1 --spin-up-cache "$out/spin-up" \
    >"$out/$2-s$3.log" 2>&1
}

for seed in "${seeds[@]}"; do
  for v in lab turning shares; do variant "base_$v" "$seed" keep keep; done
  variant lab "$seed" false false
  variant turning "$seed" true false
  variant shares "$seed" true true
done
for seed in "${seeds[@]}"; do
  for v in lab turning shares; do
    run "$base" "base_$v" "$seed" &
    run "$millsim" "$v" "$seed"
    wait
  done
done
python3 bench/rotating_frame_table.py "$out"
