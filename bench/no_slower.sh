#!/usr/bin/env bash
# Whether a change slowed the scenes it did not aim at: this build against another build (BASE, a
# build directory with bench/bench_step and cli/millsim) on the shared DEM benchmark scenes
# (bench_step SCENE --steps 1000, particle-steps per second) and on the fluidized bed
# (cases/fluidized_bed.json without run.h5, the time stepping: the sum of the phases), each three
# times, the two builds alternately, pinned to one core. Prints one line per run; compare as
# ratios of the pairs (the machine is noisy). About 10 minutes; a benchmark, not CI.
#   bash bench/no_slower.sh BASE_BUILD_DIR [OUT_DIR [SCENES_DIR]]
# SCENES_DIR holds mono.txt, r10.txt, r100.txt and burst.txt (../shared/bench/gen_particles.py
# --scene all --out DIR); made there when missing.
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:?usage: bash bench/no_slower.sh BASE_BUILD_DIR [OUT_DIR [SCENES_DIR]]}
out=${2:-/tmp/millsim-no-slower}
scenes=${3:-$out/scenes}
mkdir -p "$out" "$scenes"
[[ -f $scenes/burst.txt ]] || /usr/bin/python3 ../shared/bench/gen_particles.py --scene all --out "$scenes"
cp "$base/bench/bench_step" "$out/bench_step_base" && cp "$base/cli/millsim" "$out/millsim_base"
cp build/bench/bench_step "$out/bench_step_here" && cp build/cli/millsim "$out/millsim_here"
python3 -c "
import json, sys
s = json.load(open('cases/fluidized_bed.json'))
s.setdefault('output', {})['h5'] = False
json.dump(s, open(sys.argv[1], 'w'))
" "$out/bed.json"
for scene in r10 r100 burst mono; do
  for rep in 1 2 3; do
    for build in base here; do
      rate=$(taskset -c 1 "$out/bench_step_$build" "$scenes/$scene.txt" --steps 1000 --json 2>/dev/null |
        python3 -c "import json, sys; print(json.load(sys.stdin)['particle_steps_per_second'])")
      echo "$scene $rep $build $rate"
    done
  done
done
for rep in 1 2 3; do
  for build in base here; do
    taskset -c 1 "$out/millsim_$build" run "$out/bed.json" --out "$out/bed-$build-$rep" >/dev/null 2>&1
    python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
print('fluidized_bed', sys.argv[2], sys.argv[3], round(sum(v for k, v in r['phase_seconds'].items() if k != 'output'), 3), r['gas']['cfd_steps'])
" "$out/bed-$build-$rep/result.json" "$rep" "$build"
  done
done
