#!/usr/bin/env bash
# Dust-threshold scan (§5): runs a breakage scene once per threshold, one run after another on
# one core, and prints per threshold the wall time, steps, time step, particle-steps, breakage
# counts, the dust, outlet and held-up mass, d10/d50/d90 of the product (outlet + dust) and of
# all mass (product + hold-up), and each run's KS distance (all mass) to the smallest
# threshold's run, the most accurate.
#   bash bench/dust_threshold_scan.sh [scene.json] [thresholds...]
# Defaults: cases/attrition_target.json, 4e-5 2e-5 1e-5. Needs a built build/cli/millsim.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-cases/attrition_target.json}
shift || true
thresholds=${*:-4e-5 2e-5 1e-5}
work=$(mktemp -d /tmp/millsim-dust-scan.XXXXXX)
for t in $thresholds; do
  python3 - "$scene" "$t" "$work/scene_$t.json" <<'PY'
import json, sys
scene = json.load(open(sys.argv[1]))
scene["dust"]["threshold_diameter_m"] = float(sys.argv[2])
scene["name"] = scene["name"] + "_dust_" + sys.argv[2]
scene.setdefault("output", {})["h5"] = False
json.dump(scene, open(sys.argv[3], "w"), indent=1)
PY
  ./build/cli/millsim run "$work/scene_$t.json" --out "$work/out_$t" > /dev/null 2>"$work/log_$t" || true
done
python3 - "$work" $thresholds <<'PY'
import json, math, sys
work, ts = sys.argv[1], sys.argv[2:]
runs = {t: json.load(open(f"{work}/out_{t}/result.json")) for t in ts}
ref = runs[min(ts, key=float)]["total_psd"]["cumulative_mass"]
print("| dust threshold | status | wall s | steps | dt s | particle-steps | events (crush) | fragments | dust mass kg | outlet mass kg | held-up mass kg | product d10 / d50 / d90 µm | all-mass d10 / d50 / d90 µm | KS to smallest |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for t in ts:
    r = runs[t]; p = r["outlet_psd"]; a = r["total_psd"]; b = r["breakage"]; m = r["mass_balance"]
    ks = max(abs(x - y) for x, y in zip(r["total_psd"]["cumulative_mass"], ref))
    ps = r["particle_steps_per_second"] * sum(r["phase_seconds"].values())
    print(f"| {float(t)*1e6:g} µm | {r['status']} | {r['wall_time_s']:.1f} | {r['steps']} | {r['time_step_s']:.3g} | {ps:.3g} | "
          f"{b['events']} ({b['crush_events']}) | {b['fragments']} | {m['dust_kg']:.3g} | {m['outlet_kg']:.3g} | {m['particles_kg']:.3g} | "
          f"{p['d10_m']*1e6:.1f} / {p['d50_m']*1e6:.1f} / {p['d90_m']*1e6:.1f} | "
          f"{a['d10_m']*1e6:.1f} / {a['d50_m']*1e6:.1f} / {a['d90_m']*1e6:.1f} | {ks:.3f} |")
PY
rm -rf "$work"
