#!/usr/bin/env bash
# What a second core can give one run on this machine, measured beside what it gives.
#
#   bash bench/threads_ceiling.sh [SCENES] [ROUNDS] [STEPS]   e.g. bash bench/threads_ceiling.sh "mono burst" 3
#
# Per scene and round, in one go: the scene alone on one thread (t1), two copies of that run at
# once, one per core (tA, tB: what the machine's shared caches, memory and host let two cores do
# together), and the scene on two threads (t2). Prints, per round, the two-thread speed-up t1/t2
# and the co-run ceiling 2·t1/max(tA, tB): the throughput two independent one-thread runs get
# from the two cores, which one run on two threads cannot beat by sharing its work. Loop seconds
# of bench_step (--json: loop_seconds). Scenes from shared/bench/gen_particles.py.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/.." && pwd)
shared=${SHARED:-$root/../shared}
scenes=${1:-"mono r10 r100 burst"}
rounds=${2:-3}
steps=${3:-1000}
work=${WORK:-/tmp/millsim-peers/data}
bench=${BENCH:-$root/build/bench/bench_step}
mkdir -p "$work"

loop_s() {  # loop_s SCENE THREADS
  "$bench" "$work/$1.txt" --steps "$steps" --json --threads "$2" |
    /usr/bin/python3 -c 'import json, sys; print(json.load(sys.stdin)["loop_seconds"])'
}

printf "| scene | round | t1 s | co-run tA, tB s | t2 s | 2 threads t1/t2 | co-run ceiling 2·t1/max(tA,tB) |\n"
printf "| --- | --- | --- | --- | --- | --- | --- |\n"
for scene in $scenes; do
  [ -f "$work/$scene.txt" ] ||
    /usr/bin/python3 "$shared/bench/gen_particles.py" --scene "$scene" --out "$work" >/dev/null
  for round in $(seq 1 "$rounds"); do
    t1=$(loop_s "$scene" 1)
    a_file=$(mktemp) b_file=$(mktemp)
    loop_s "$scene" 1 >"$a_file" &
    a_pid=$!
    loop_s "$scene" 1 >"$b_file" &
    b_pid=$!
    wait "$a_pid" "$b_pid"
    ta=$(cat "$a_file") tb=$(cat "$b_file")
    rm -f "$a_file" "$b_file"
    t2=$(loop_s "$scene" 2)
    /usr/bin/python3 -c "
t1, ta, tb, t2 = $t1, $ta, $tb, $t2
print('| $scene | $round | %.3f | %.3f, %.3f | %.3f | %.2f | %.2f |' % (t1, ta, tb, t2, t1 / t2, 2 * t1 / max(ta, tb)))"
  done
done
