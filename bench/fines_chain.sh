#!/usr/bin/env bash
# The paper's acceleration chain in the regime it describes (cases/jet_mill_fines_chain.study.json):
# three 100 um parents break at the mill's mantle into about 20 000 fragments down to 1 um, and
# seven stages follow the same 4 us one after another on one core (--workers 1, so times compare).
# Then:
#  - the stage table: time stepping per simulated us and each speed-up's three factors
#    (bench/study_stages.py --factors);
#  - the fines-to-tracked ratio of the reference run's last snapshot (needs python3-h5py);
#  - stage (a0) with millsim's dense NBS array instead of the hashed uniform grid, both searched
#    every step, over the first 1 us (DENSE_END_S=4e-6 for the whole span: the dense array sweeps
#    every cell of the chamber's box at each search, about 50 minutes more on this machine).
#   [DENSE_END_S=4e-6] bash bench/fines_chain.sh [OUT_DIR]        # about 25 minutes
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/millsim-fines-chain}
mkdir -p "$out"
./build/cli/millsim study cases/jet_mill_fines_chain.study.json --local --workers 1 \
  --db "$out/chain.db" --out "$out/studies"
study=$(ls -d "$out"/studies/s* | tail -n 1)
labels="(f) + dust threshold 10 um,(e) + drag cache 5 %,(d) + reduced stiffness,(c) + sub-grid and levels"
labels+=",(b) hashed grid + Verlet list,(a) dense NBS + Verlet list,(a0) uniform grid searched every step"
python3 bench/study_stages.py "$study" --factors --reverse --labels "$labels"

reference=$(ls -d "$study"/*-r6)
/usr/bin/python3 - "$reference/run.h5" <<'PY'
import sys
import h5py
with h5py.File(sys.argv[1], "r") as f:
    last = sorted(f["snapshots"].keys())[-1]
    d = f["snapshots"][last]["diameter"][:]
fines = int(((d >= 1e-6) & (d < 10e-6)).sum())
tracked = int((d >= 10e-6).sum())
print(f"reference's last snapshot ({last}): {d.size} particles, {fines} of 1-10 um and {tracked} "
      f"of 10 um or more: fines to tracked {fines / max(tracked, 1):.1f} : 1")
PY

# (a0) with the dense array against the hashed grid, both searched every step.
end_s=${DENSE_END_S:-1e-6}
for method in nbs hashed; do
  python3 - "$reference/scene.json" "$out/a0_$method.json" "$method" "$end_s" <<'PY'
import json, sys
scene = json.load(open(sys.argv[1]))
scene["search"]["method"] = sys.argv[3]
scene["time"]["end_s"] = float(sys.argv[4])
scene["output"]["h5"] = False
json.dump(scene, open(sys.argv[2], "w"))
PY
  ./build/cli/millsim run "$out/a0_$method.json" --out "$out/a0_$method" --quiet \
    --spin-up-cache "$study/spin-up-cache" --threads 1 > /dev/null 2>&1
done
python3 - "$out/a0_nbs/result.json" "$out/a0_hashed/result.json" <<'PY'
import json, sys
for path in sys.argv[1:]:
    r = json.load(open(path))
    stepping = sum(r["phase_seconds"].values())
    print(f"{r['search']['method']:6s} searched every step, {r['simulated_time_s'] * 1e6:.2f} us: "
          f"{stepping:.1f} s stepping ({r['phase_seconds']['neighbors']:.1f} s searching), "
          f"{r['steps']} steps, {r['search']['distance_tests']:.3g} distance tests, "
          f"{r['search']['occupied_cells']} cells")
PY
