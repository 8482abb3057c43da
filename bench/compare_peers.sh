#!/usr/bin/env bash
# Same-session comparison of millsim against LAMMPS on the shared benchmark scenes.
#
#   bash bench/compare_peers.sh [SCENES] [REPS]      e.g.  bash bench/compare_peers.sh "mono r100" 3
#
# For each scene: generates it with shared/bench/gen_particles.py, converts it for LAMMPS with
# shared/bench/peers/scene2data.py, then runs millsim's bench_step (default settings) and LAMMPS
# (its best-tuned settings from shared/bench/peers/RESULTS.md) alternately REPS times, one core
# each, 1000 steps. Prints loop-time particle-steps per second of both and the median of the
# per-pair ratios millsim/LAMMPS. Needs: apt-get install lammps python3-numpy.
# CORES=N (default 1): millsim with --threads N against LAMMPS on N MPI ranks (mpirun -np N).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
shared=${SHARED:-$root/../shared}
scenes=${1:-"mono r10 r100 burst"}
reps=${2:-3}
work=${WORK:-/tmp/millsim-peers}
bench=${BENCH:-$root/build/bench/bench_step}
cores=${CORES:-1}
lammps=(lmp)
if [ "$cores" -gt 1 ]; then lammps=(mpirun --allow-run-as-root --oversubscribe -np "$cores" lmp); fi
mkdir -p "$work/decks" "$work/data"
cp "$shared/bench/peers/decks/"* "$work/decks/"

lammps_args() {  # best-tuned settings per scene (shared/bench/peers/RESULTS.md)
  case "$1" in
    mono) echo "in.lammps.bin -var skin 2.5e-5" ;;
    r10) echo "in.lammps.bin -var skin 1e-5" ;;
    r100) echo "in.lammps.multi -var skin 2e-6 -var coll 3_4e-6_2e-5_1.001e-4" ;;
    burst) echo "in.lammps.multi -var skin 2e-6 -var coll 3_4e-6_2.001e-5_1.001e-4" ;;
  esac
}

printf "| scene | N | millsim particle-steps/s | LAMMPS particle-steps/s | ratio millsim/LAMMPS (median of %s pairs) |\n| --- | --- | --- | --- | --- |\n" "$reps"
for scene in $scenes; do
  [ -f "$work/data/$scene.txt" ] || /usr/bin/python3 "$shared/bench/gen_particles.py" --scene "$scene" --out "$work/data" >/dev/null
  [ -f "$work/data/$scene.data" ] || /usr/bin/python3 "$shared/bench/peers/scene2data.py" "$work/data/$scene.txt" >/dev/null
  n=$(sed -n 's/^# N: //p' "$work/data/$scene.txt")
  read -r deck rest <<< "$(lammps_args "$scene")"
  extra=()
  for word in $rest; do extra+=("${word//_/ }"); done
  ours=() theirs=() ratios=()
  for ((r = 1; r <= reps; r++)); do
    m=$("$bench" "$work/data/$scene.txt" --steps 1000 --json --threads "$cores" |
      sed -n 's/.*"loop_seconds": \([0-9.e+-]*\).*/\1/p')
    (cd "$work/data" && OMP_NUM_THREADS=1 "${lammps[@]}" -nocite -in "../decks/$deck" -var base "$scene" "${extra[@]}" \
       -log "log.$scene.$r" >/dev/null)
    l=$(sed -n 's/^Loop time of \([0-9.e+-]*\) on.*/\1/p' "$work/data/log.$scene.$r" | head -1)
    ours+=("$m") theirs+=("$l") ratios+=("$(awk -v a="$m" -v b="$l" 'BEGIN{print b/a}')")
  done
  median() { printf "%s\n" "$@" | sort -g | awk '{v[NR]=$1} END{print v[int((NR+1)/2)]}'; }
  mo=$(median "${ours[@]}") lo=$(median "${theirs[@]}") ra=$(median "${ratios[@]}")
  awk -v s="$scene" -v n="$n" -v m="$mo" -v l="$lo" -v r="$ra" \
    'BEGIN{printf "| %s | %d | %.3g | %.3g | %.2f |\n", s, n, n*1000/m, n*1000/l, r}'
done
