#!/usr/bin/env bash
# Builds the libFuzzer harnesses (fuzz/, docs/fuzzing.md) with clang, ASan and UBSan in
# build-fuzz/, then runs each on a copy of its seed corpus:
#   bash deploy/fuzz.sh            30 s per harness (what CI runs)
#   bash deploy/fuzz.sh 600        10 minutes each
#   bash deploy/fuzz.sh runs 1000000   a million inputs each (the run in bench/RESULTS.md)
# Exits 1 when a harness finds a crash; its input is left in build-fuzz/work/<harness>/.
set -euo pipefail
cd "$(dirname "$0")/.."

mode=time
limit=${1:-30}
if [ "${1:-}" = runs ]; then
  mode=runs
  limit=${2:-1000000}
fi
command -v clang++ >/dev/null 2>&1 || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang >/dev/null
bash deploy/install-deps.sh >/dev/null

CC=clang CXX=clang++ cmake -S . -B build-fuzz -DMILLSIM_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DMILLSIM_BUILD_TESTS=OFF -DMILLSIM_BUILD_BENCH=OFF >/dev/null
cmake --build build-fuzz -j"$(nproc)" --target fuzz_scene fuzz_study fuzz_http >/dev/null

root=$(pwd)
status=0
for harness in fuzz_scene fuzz_study fuzz_http; do
  work=build-fuzz/work/$harness
  rm -rf "$work"
  mkdir -p "$work/corpus" "$work/fuzz-empty"
  case $harness in
    fuzz_scene) find cases -name '*.json' ! -name '*.study.json' -exec cp {} "$work/corpus/" \; ;;
    fuzz_study) cp cases/*.study.json "$work/corpus/" ;;
    fuzz_http) cp fuzz/http_seeds/* "$work/corpus/" ;;
  esac
  if [ $mode = runs ]; then budget="-runs=$limit"; else budget="-max_total_time=$limit"; fi
  echo "== $harness ($budget)"
  if ! (cd "$work" && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
        "$root/build-fuzz/fuzz/$harness" corpus -max_len=65536 -timeout=20 -rss_limit_mb=3072 \
        -print_final_stats=1 "$budget" > log.txt 2>&1); then
    echo "$harness: FOUND A CRASH (build-fuzz/work/$harness/log.txt, crash-* inputs there)"
    tail -40 "$work/log.txt"
    status=1
  fi
  grep -E "^stat::number_of_executed_units|^stat::peak_rss_mb|^#[0-9]+.*DONE" "$work/log.txt" || true
done
exit $status
