#!/usr/bin/env bash
# The README's quick start. On a fresh Debian 12 machine (as root, or with sudo):
#   bash deploy/quickstart.sh run        build, then run the default study locally and print its results
#   bash deploy/quickstart.sh test       build, then run the whole test suite
#   bash deploy/quickstart.sh sanitize   build with AddressSanitizer + UBSan, then run the tests
#   bash deploy/quickstart.sh tsan       build the threaded tests with ThreadSanitizer and run them
# Installs missing Debian packages first (deploy/install-deps.sh).
set -euo pipefail
cd "$(dirname "$0")/.."

mode=${1:-run}
jobs=$(nproc 2>/dev/null || echo 2)
bash deploy/install-deps.sh

# Shows the build's percentage on stderr: in place on a terminal, every 10 % in a log.
progress() {  # progress DIR < build output
  local line pct last=-10
  while IFS= read -r line; do
    [[ $line =~ ^\[\ *([0-9]+)%\] ]] || continue
    pct=${BASH_REMATCH[1]}
    if [ -t 2 ]; then
      printf '\rbuilding %s: %3d%%' "$1" "$pct" >&2
    elif [ $((pct / 10)) -gt $((last / 10)) ]; then
      echo "building $1: $pct%" >&2
      last=$pct
    fi
  done
  if [ -t 2 ]; then echo >&2; fi
}

build() {  # build DIR [cmake options...]; MILLSIM_CMAKE_ARGS adds more (CI: -DMILLSIM_WERROR=ON)
  local dir=$1
  shift
  echo "configuring $dir (the first build takes a few minutes)" >&2
  # shellcheck disable=SC2086
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release "$@" ${MILLSIM_CMAKE_ARGS:-} >/dev/null
  if ! cmake --build "$dir" -j"$jobs" 2>&1 | tee "$dir/build.log" | progress "$dir"; then
    tail -n 40 "$dir/build.log" >&2
    echo "the build failed; the whole log is $dir/build.log" >&2
    exit 1
  fi
}

case "$mode" in
  run)
    build build
    # The main job: a whole parameter study run locally on an embedded SQLite file (out/millsim.db).
    ./build/cli/millsim study cases/spiral_jet_mill_quick_scan.study.json --local
    ;;
  test)
    build build
    (cd build && ctest -j"$jobs" --output-on-failure)
    ;;
  sanitize)
    # clang: it compiles the instrumented tree in about half g++'s time (the fuzzing build's
    # compiler too); g++ builds and checks the warnings of the other two modes.
    command -v clang++ >/dev/null 2>&1 ||
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends clang >/dev/null
    build build-sanitize -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
      -DMILLSIM_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMILLSIM_BUILD_BENCH=OFF
    (cd build-sanitize && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
       ctest -j"$jobs" --output-on-failure)
    ;;
  tsan)
    # The engine's threaded loops under ThreadSanitizer: the threaded tests alone (their own
    # target, without the service), at 1, 2 and 3 threads (docs/threads.md).
    command -v clang++ >/dev/null 2>&1 ||
      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends clang >/dev/null
    cmake -S . -B build-tsan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
      -DCMAKE_CXX_COMPILER=clang++ -DMILLSIM_TSAN=ON -DMILLSIM_BUILD_BENCH=OFF >/dev/null
    if ! cmake --build build-tsan -j"$jobs" --target millsim_thread_tests 2>&1 |
      tee build-tsan/build.log | progress build-tsan; then
      tail -n 40 build-tsan/build.log >&2
      exit 1
    fi
    TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" ./build-tsan/tests/millsim_thread_tests
    ;;
  *)
    echo "usage: bash deploy/quickstart.sh run|test|sanitize|tsan" >&2
    exit 2
    ;;
esac
